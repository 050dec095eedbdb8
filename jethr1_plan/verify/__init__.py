"""``jethr1 verify``: independent re-checks of written plans and walks."""

from jethr1_plan.verify import timing as _timing  # noqa: F401  (the checks of a plan timed fastest, registered last)
