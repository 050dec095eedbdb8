"""``jethr1 view`` (:func:`.show.view`): a plan folder (with its rehearsal, if simulated), a route folder (its plan and
``route.mcap``), a walk folder or a balance space in Rerun, from the MCAP files written there (what the
files say, not what a planner remembers).

The robot is built from the URDF each file carries and moved by its ``/tf`` (the rehearsal's frames
prefixed ``sim/``, so both robots play in one scene); the markers (cartons, swing paths,
footsteps, the support sole, the balance-space cells, the route's footholds) become boxes, lines and
labelled points; point clouds (the balance space's, the slices a route judged each step on) become
points coloured by their first value (the least thrust); CoM, ZMP and the other poses become moving
points; the thrust of each fan (planned and applied), its window, the ZMP margin and a walk's figures
become plots. One timeline, ``time``: seconds from the start.

Rerun is an optional extra (``pip install 'jethr1-plan[view]'``); nothing here imports it until a
view is asked for.
"""

__all__: list[str] = []
