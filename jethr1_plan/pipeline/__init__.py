"""From an input file to a written, re-checked output folder: a scenario's plan
(:mod:`.plan`) and a walk (:mod:`.walk`)."""
