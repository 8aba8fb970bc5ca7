"""What robot ports carry: the roles sinks match on (the viewer today; ROS 2 and MCAP publishers next).

A role is declared on a port (``Output(..., role=LINK_POSES)``) and is an
opaque string to the framework. The row and element orders are the robot's
(:class:`~snakesim.components.multibody.RobotModel`): ``links`` for per-link
arrays, ``joints`` for per-joint ones. Units SI, frames as stated.
"""

#: [nl, 7] each link's origin and orientation in the world: x, y, z (m), qx, qy, qz, qw
LINK_POSES = "link_poses"
#: [nl, 6] each link's origin velocity and angular velocity, world axes (m/s, rad/s)
LINK_VELOCITIES = "link_velocities"
#: [nj] DOF joint positions, rad (continuous joints wrapped to (-π, π])
JOINT_POSITIONS = "joint_positions"
#: [nj] DOF joint rates, rad/s
JOINT_VELOCITIES = "joint_velocities"
#: [nj] joint torques commanded to the multibody, N·m
JOINT_EFFORTS = "joint_efforts"
#: [nl, 6] wrench across each link's parent joint, [f N, τ N·m] in the link frame about its origin
JOINT_WRENCHES = "joint_wrenches"
#: [n, 6] force-torque sensor readings, [f N, τ N·m] in each sensor frame (WrenchStamped order)
SENSOR_WRENCHES = "sensor_wrenches"
#: [3] rad/s body angular rate, [3] m/s² specific force, [4] xyzw orientation of an IMU frame
IMU_ANGULAR_RATE = "imu_angular_rate"
IMU_SPECIFIC_FORCE = "imu_specific_force"
IMU_ORIENTATION = "imu_orientation"
#: LidarScan (components/perception/lidar.py): one lidar sample, points in the lidar frame
LIDAR_SCAN = "lidar_scan"
#: CameraFrame (components/perception/camera.py): one camera image with depth, optical frame
CAMERA_FRAME = "camera_frame"
