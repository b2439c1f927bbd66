"""The ROS 2 message types a bag of hriplan's motions holds, for the pure-Python `rosbags` library.

rosbags ships the core ROS 2 messages (std_msgs, sensor_msgs, trajectory_msgs, shape_msgs, ...)
but not MoveIt's: `moveit_msgs/msg/DisplayTrajectory` and the messages it is made of are
registered here from their .msg text, so the bag embeds their definitions as a ROS 2 recorder
would and any reader decodes them without MoveIt installed. The text is the field lines of
moveit_msgs 2.6.0 (github.com/moveit/moveit_msgs, branch ros2; humble's 2.2.1 has the same fields)
and of object_recognition_msgs' ObjectType (github.com/wg-perception/object_recognition_msgs),
their comments left out (a comment is no part of a message's type or hash).
"""

from __future__ import annotations

from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

# The ROS 2 distribution whose core message definitions the bag carries (Jazzy, the LTS of 2024;
# the messages used here are the same in Humble).
STORE = Stores.ROS2_JAZZY

MESSAGES = {
    "object_recognition_msgs/msg/ObjectType": """
string key
string db
""",
    "moveit_msgs/msg/CollisionObject": """
std_msgs/Header header
geometry_msgs/Pose pose
string id
object_recognition_msgs/ObjectType type
shape_msgs/SolidPrimitive[] primitives
geometry_msgs/Pose[] primitive_poses
shape_msgs/Mesh[] meshes
geometry_msgs/Pose[] mesh_poses
shape_msgs/Plane[] planes
geometry_msgs/Pose[] plane_poses
string[] subframe_names
geometry_msgs/Pose[] subframe_poses
byte ADD=0
byte REMOVE=1
byte APPEND=2
byte MOVE=3
byte operation
""",
    "moveit_msgs/msg/AttachedCollisionObject": """
string link_name
CollisionObject object
string[] touch_links
trajectory_msgs/JointTrajectory detach_posture
float64 weight
""",
    "moveit_msgs/msg/RobotState": """
sensor_msgs/JointState joint_state
sensor_msgs/MultiDOFJointState multi_dof_joint_state
AttachedCollisionObject[] attached_collision_objects
bool is_diff
""",
    "moveit_msgs/msg/RobotTrajectory": """
trajectory_msgs/JointTrajectory joint_trajectory
trajectory_msgs/MultiDOFJointTrajectory multi_dof_joint_trajectory
""",
    "moveit_msgs/msg/DisplayTrajectory": """
string model_id
RobotTrajectory[] trajectory
RobotState trajectory_start
""",
}


def typestore() -> Typestore:
    """A new type store: the ROS 2 core messages and MoveIt's DisplayTrajectory with its parts."""
    store = get_typestore(STORE)
    for name, text in MESSAGES.items():
        store.register(get_types_from_msg(text, name))
    return store
