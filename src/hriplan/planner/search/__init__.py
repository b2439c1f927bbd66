"""Path search over the planned joints: hriplan's CBiRRT, OMPL's planners, arm-wise shortcuts."""
