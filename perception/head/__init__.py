"""The robot's head and its cameras: the kinematic chain from the ego frame to the cameras
(:mod:`~perception.head.chain`, read from URDF by :mod:`~perception.head.urdf`), the calibrated
stereo rig (:mod:`~perception.head.stereo`) and the stereo uncertainty model, sigma = rho^2 /
depth_factor (:mod:`~perception.head.uncertainty`)."""
