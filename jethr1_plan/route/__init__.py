"""``jethr1 route``: footholds chosen over a field of cartons on the balance space, then planned for
real: terrain files and random carton fields (:mod:`.terrain`), the cached balance-space maps
(:mod:`.balance_map`), the footstep search (:mod:`.search`), and the route planned and written
(:mod:`.planner`)."""
