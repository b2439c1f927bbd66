"""Robot descriptions: each robot's URDF and what an SRDF adds to it (groups, arms, tools, hands, postures)."""
