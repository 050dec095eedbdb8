"""``jethr1 verify``: independent re-checks of written plans and walks."""
