#!/usr/bin/python3
"""A stand-in for appliedAI-Initiative/orb_slam_2_ros's RGB-D node (orb_slam2_ros_rgbd), for the tests.

It has the wrapper's interface as the wrapper's ROS 1 code has it (ros/src/Node.cc at 09b82abf,
ros/src/RGBDNode.cc at 2c9397bf; read, not copied: docs/live_camera.md), and takes its camera poses from a
trajectory file instead of tracking:

- parameters (private): voc_file, pointcloud_frame_id (map), camera_frame_id (camera_link), target_frame_id
  (base_link), publish_pose, publish_tf, publish_pointcloud (true each), load_calibration_from_cam (false),
  camera_fx, camera_fy, camera_cx, camera_cy, camera_k1..k3, camera_p1, camera_p2, camera_baseline (no
  defaults), depth_map_factor (1.0), ThDepth (35), camera_fps (30), camera_rgb_encoding (true). Without
  calibration (neither load_calibration_from_cam nor the camera_* parameters) it logs the wrapper's error and
  exits ("No cam calibration"). With load_calibration_from_cam it waits for /camera/rgb/camera_info.
- topics: /camera/rgb/image_raw and /camera/depth_registered/image_raw, subscriber queues of 1, an
  approximate-time pair of queue 10; publishes ~pose (PoseStamped, frame pointcloud_frame_id) and TF
  pointcloud_frame_id -> target_frame_id, both stamped with the colour image's stamp. It publishes no
  keyframes.
- the pose: ORB-SLAM2's camera pose (optical axes, world = the first camera) converted to ROS body axes for the
  camera and for the map (T_map_cam = M T_wc M^T, M the optical-to-body rotation), then composed with the TF
  camera_frame_id -> target_frame_id looked up at the latest time; a failed look-up is warned at every frame and
  replaced by the identity, as the wrapper does.

The test-only input: the trajectory, TUM format 't tx ty tz qx qy qz qw' (the colour camera's optical frame in
ORB-SLAM2's world, e.g. its CameraTrajectory.txt), from ~trajectory_file or $MVOD_ORBSLAM2_STANDIN_TRAJECTORY;
an image whose stamp has no pose within 1 ms is 'tracking lost' (nothing published for it), as ORB-SLAM2 is.
"""
import os
import sys

import numpy as np


def quaternion_to_matrix(qx, qy, qz, qw):
    q = np.array([qw, qx, qy, qz], dtype=float)
    q /= np.linalg.norm(q)
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def matrix_to_quaternion(R):
    """(x, y, z, w) of a rotation matrix."""
    w = np.sqrt(max(0.0, 1.0 + R[0, 0] + R[1, 1] + R[2, 2])) / 2.0
    x = np.sqrt(max(0.0, 1.0 + R[0, 0] - R[1, 1] - R[2, 2])) / 2.0
    y = np.sqrt(max(0.0, 1.0 - R[0, 0] + R[1, 1] - R[2, 2])) / 2.0
    z = np.sqrt(max(0.0, 1.0 - R[0, 0] - R[1, 1] + R[2, 2])) / 2.0
    x = np.copysign(x, R[2, 1] - R[1, 2])
    y = np.copysign(y, R[0, 2] - R[2, 0])
    z = np.copysign(z, R[1, 0] - R[0, 1])
    return x, y, z, w


def read_trajectory(path):
    """{stamp: 4x4 T_w_c} of a TUM file."""
    poses = {}
    with open(path) as f:
        for line in f:
            fields = line.split()
            if len(fields) != 8 or line.startswith('#'):
                continue
            t, tx, ty, tz, qx, qy, qz, qw = (float(v) for v in fields)
            T = np.eye(4)
            T[:3, :3] = quaternion_to_matrix(qx, qy, qz, qw)
            T[:3, 3] = (tx, ty, tz)
            poses[t] = T
    return poses


# ORB-SLAM2's optical axes (x right, y down, z forward) to ROS body axes (x forward, y left, z up).
ORB_TO_ROS = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])


def ros_pose_of(T_w_c):
    """The wrapper's TransformFromMat: the camera in the map, both in ROS body axes."""
    T = np.eye(4)
    T[:3, :3] = ORB_TO_ROS @ T_w_c[:3, :3] @ ORB_TO_ROS.T
    T[:3, 3] = ORB_TO_ROS @ T_w_c[:3, 3]
    return T


class StandIn:
    def __init__(self):
        import rospy
        import tf2_ros
        self.rospy = rospy
        p = lambda name, default: rospy.get_param('~' + name, default)  # noqa: E731
        self.map_frame = p('pointcloud_frame_id', 'map')
        self.camera_frame = p('camera_frame_id', 'camera_link')
        self.target_frame = p('target_frame_id', 'base_link')
        self.publish_pose = p('publish_pose', True)
        self.publish_tf = p('publish_tf', True)
        self.voc_file = p('voc_file', 'file_not_set')
        self.depth_map_factor = float(p('depth_map_factor', 1.0))
        self.calibration_from_camera = p('load_calibration_from_cam', False)
        names = ['camera_fx', 'camera_fy', 'camera_cx', 'camera_cy', 'camera_k1', 'camera_k2', 'camera_p1',
                 'camera_p2', 'camera_k3', 'camera_baseline']
        self.calibration = {n: rospy.get_param('~' + n) for n in names if rospy.has_param('~' + n)}
        if not self.calibration_from_camera and len(self.calibration) != len(names):
            rospy.logerr('Failed to get camera calibration parameters from the launch file.')
            raise RuntimeError('No cam calibration')
        path = p('trajectory_file', os.environ.get('MVOD_ORBSLAM2_STANDIN_TRAJECTORY', ''))
        if not path or not os.path.isfile(path):
            raise RuntimeError('orbslam2_standin: no trajectory file (~trajectory_file or '
                               '$MVOD_ORBSLAM2_STANDIN_TRAJECTORY): %r' % path)
        self.poses = read_trajectory(path)
        self.stamps = np.array(sorted(self.poses))
        self.tf_buffer = tf2_ros.Buffer()
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.broadcaster = tf2_ros.TransformBroadcaster()
        from geometry_msgs.msg import PoseStamped
        self.pose_publisher = rospy.Publisher('~pose', PoseStamped, queue_size=1)
        self.frames = 0
        self.lost = 0

    def wait_for_camera_info(self):
        from sensor_msgs.msg import CameraInfo
        if not self.calibration_from_camera:
            return
        try:
            info = self.rospy.wait_for_message('/camera/rgb/camera_info', CameraInfo, timeout=1000)
            self.calibration.update(camera_fx=info.K[0], camera_fy=info.K[4], camera_cx=info.K[2],
                                    camera_cy=info.K[5])
        except self.rospy.ROSException:
            self.rospy.logwarn('Did not receive camera info before timeout, defaulting to launch file params.')

    def subscribe(self):
        import message_filters
        from sensor_msgs.msg import Image
        rgb = message_filters.Subscriber('/camera/rgb/image_raw', Image, queue_size=1)
        depth = message_filters.Subscriber('/camera/depth_registered/image_raw', Image, queue_size=1)
        self.sync = message_filters.ApproximateTimeSynchronizer([rgb, depth], 10, 0.1)
        self.sync.registerCallback(self.on_images)

    def on_images(self, rgb, _depth):
        stamp = rgb.header.stamp
        self.frames += 1
        t = stamp.to_sec()
        k = int(np.searchsorted(self.stamps, t))
        best = min((abs(self.stamps[i] - t), i) for i in (k - 1, k) if 0 <= i < len(self.stamps))
        if best[0] > 1e-3:
            self.lost += 1  # ORB-SLAM2 lost: it publishes nothing for this frame
            return
        T_map_cam = ros_pose_of(self.poses[self.stamps[best[1]]])
        self.publish(T_map_cam @ self.camera_to_target(), stamp)

    def camera_to_target(self):
        import tf2_ros
        T = np.eye(4)
        try:
            tf = self.tf_buffer.lookup_transform(self.camera_frame, self.target_frame, self.rospy.Time(0))
        except (tf2_ros.LookupException, tf2_ros.ConnectivityException, tf2_ros.ExtrapolationException) as e:
            self.rospy.logwarn('%s' % e)
            return T
        q = tf.transform.rotation
        T[:3, :3] = quaternion_to_matrix(q.x, q.y, q.z, q.w)
        v = tf.transform.translation
        T[:3, 3] = (v.x, v.y, v.z)
        return T

    def publish(self, T_map_target, stamp):
        from geometry_msgs.msg import PoseStamped, TransformStamped
        x, y, z, w = matrix_to_quaternion(T_map_target[:3, :3])
        tx, ty, tz = T_map_target[:3, 3]
        if self.publish_tf:
            tf = TransformStamped()
            tf.header.stamp = stamp
            tf.header.frame_id = self.map_frame
            tf.child_frame_id = self.target_frame
            tf.transform.translation.x, tf.transform.translation.y, tf.transform.translation.z = tx, ty, tz
            tf.transform.rotation.x, tf.transform.rotation.y = x, y
            tf.transform.rotation.z, tf.transform.rotation.w = z, w
            self.broadcaster.sendTransform(tf)
        if self.publish_pose:
            pose = PoseStamped()
            pose.header.stamp = stamp
            pose.header.frame_id = self.map_frame
            pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = tx, ty, tz
            pose.pose.orientation.x, pose.pose.orientation.y = x, y
            pose.pose.orientation.z, pose.pose.orientation.w = z, w
            self.pose_publisher.publish(pose)


def main():
    import rospy
    rospy.init_node('orb_slam2_rgbd')
    try:
        node = StandIn()
    except RuntimeError as e:
        rospy.logfatal(str(e))
        return 1
    node.wait_for_camera_info()
    node.subscribe()
    rospy.spin()
    rospy.loginfo('orbslam2_standin: %d frames, %d without a pose (lost)' % (node.frames, node.lost))
    return 0


if __name__ == '__main__':
    sys.exit(main())
