"""Paper A's balance space (IV-A, Fig. 5): where the swing sole can be held, with and without thrust,
for a support sole fixed; swept over a grid of cells, each solved by the P_body search
(:mod:`jethr1_plan.optimisers.search`)."""
