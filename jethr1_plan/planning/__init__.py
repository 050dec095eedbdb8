"""Planning a scenario: its problems (:mod:`.problems`), their optimisation and the output-rate
sequence (:mod:`.plan`, :mod:`.sequence`), and what a plan reports (:mod:`.results`, :mod:`.report`)."""
