"""Studies built on the planner: the balance space, the optimisers' comparison, the ditch curve,
Paper B's reach, batches of scenarios and the walk sweep."""
