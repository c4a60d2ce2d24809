"""Simulated sensing without a renderer of your own: percepts of a scene drawn from the sensor
model (:mod:`~perception.simulation.simulate`) and synthetic box scenes rendered into stereo pairs
with OpenCV (:mod:`~perception.simulation.render`). MuJoCo scenes are :mod:`perception.mujoco`."""
