"""MADAR joint values the tests share.

RIGHT: the right hand forward at about (0, 0.9, 1.05); CLEAR adds the left arm folded up, a
collision-free state (tests/robots/test_collision.py checks it).
"""

RIGHT = dict(
    zip(
        [
            "right_shoulder_pan_joint",
            "right_shoulder_lift_joint",
            "right_elbow_joint",
            "right_wrist_1_joint",
            "right_wrist_2_joint",
            "right_wrist_3_joint",
        ],
        [0.788, 0.215, -0.332, -0.338, 0.585, -0.427],
    )
)
CLEAR = {**RIGHT, "left_shoulder_lift_joint": -2.2, "left_elbow_joint": 1.2}
