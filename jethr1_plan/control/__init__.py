"""What is sent to the robot, and the loops that run on it: servo and fan commands, the body-yaw MPC,
and the thrust feedback law."""
