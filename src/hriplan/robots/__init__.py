"""The physical world: robot descriptions and models, kinematics, IK, people, scenes, collision."""
