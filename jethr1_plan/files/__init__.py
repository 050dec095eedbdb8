"""Every file format jethr1 writes and reads, one module each: the plan folder, the walk folder,
the balance-space files, the rehearsal's files, and the ROS 2 MCAP container they share
(:mod:`.mcap`, with the CDR encoder :mod:`.cdr` and the message definitions :mod:`.ros2_msgs`)."""
