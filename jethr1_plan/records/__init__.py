"""What the planner produces, as typed records with no I/O and no solver: the plan's rows
(:mod:`.plan_rows`), its columns (:mod:`.plan_columns`), the first infeasible sample or row
(:mod:`.infeasible`) and the topics of its files (:mod:`.topics`). Every column and topic name is
spelled here once; ``files/`` serialises these records, the planner fills them."""
