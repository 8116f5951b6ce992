#!/usr/bin/python3
"""Replays a bag through object_detection_node (launch/replay.launch) and collects the result.

Used by `make demo` (scripts/demo.sh); also usable alone:

  scripts/demo_replay.py --bag scene.bag --output-dir DIR [--detector topic|fastestdet] [--model-dir DIR]
      [--gravity-down "[0, -1, 0]" | --gravity-estimate] [--keyframe-every N] [--rate R] [--no-rviz]
  scripts/demo_replay.py --bag scene.bag --output-dir DIR --launch kinect_orbslam2 --slam-trajectory TUM.txt ...

--launch kinect_orbslam2 runs the live launch file instead, with test/ros/orbslam2_standin.py in ORB-SLAM2's place
(its poses from --slam-trajectory) and freenect's static frames published here; the bag's own poses and TF are not
played, its registered depth goes to depth_registered/image_raw as freenect names it.

Starts roslaunch (its own master on a free port, so it never meets another master) with the node and, on a
virtual X display (Xvfb), rviz. Plays the bag with its clock (BagPlayer: like `rosbag play --clock`, but never
more than a few frames ahead of what the node received, so a loaded machine slows the replay down instead of
losing frames), waits on /diagnostics until every selected keyframe is processed, calls ~refine and ~save_map
(DIR/map.mvmap, the map folder), prints ~get_objects as a table, shows the map in rviz gravity-up and saves a
screenshot (DIR/rviz.png) looking at the objects. Everything it started is stopped on the way out. Exit status: 0 ok; 1 the node
failed, found nothing, or did not take every frame of the bag (lost, rejected, dropped or failed: the message
says which); 2 bad arguments.

Needs the Python message packages (Debian's python3-{std,geometry,diagnostic,sensor,visualization,tf2}-msgs,
python3-std-srvs; deps/debian-packages.txt) and this package's own, generated in the catkin devel space.
"""
import argparse
import math
import os
import shutil
import signal
import socket
import subprocess
import sys
import time

PKG = 'multiview_object_detection'
NODE = '/object_detection'
SCREEN = (1280, 960)


def log(text):
    print('[demo_replay] ' + text, flush=True)


class DemoError(Exception):
    pass


# ---------------------------------------------------------------------------------------------------------
# Processes

def free_port():
    with socket.socket() as s:
        s.bind(('localhost', 0))
        return s.getsockname()[1]


def stop(process, name, timeout_s=20):
    """SIGINT to the process group (roslaunch shuts its nodes and master down), then SIGTERM, SIGKILL."""
    if process is None or process.poll() is not None:
        return
    for sig, wait_s in ((signal.SIGINT, timeout_s), (signal.SIGTERM, 5), (signal.SIGKILL, 5)):
        try:
            os.killpg(process.pid, sig)
        except ProcessLookupError:
            return
        try:
            process.wait(timeout=wait_s)
            return
        except subprocess.TimeoutExpired:
            if sig != signal.SIGKILL:
                log('%s did not stop on %s' % (name, signal.Signals(sig).name))


def start_xvfb():
    """Xvfb on a free display; returns (process, ':N')."""
    read_fd, write_fd = os.pipe()
    xvfb = subprocess.Popen(['Xvfb', '-displayfd', str(write_fd), '-screen', '0', '%dx%dx24' % SCREEN,
                             '-nolisten', 'tcp', '-noreset'], pass_fds=(write_fd,), start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write_fd)
    with os.fdopen(read_fd) as pipe:
        number = pipe.readline().strip()
    if not number:
        stop(xvfb, 'Xvfb')
        raise DemoError('Xvfb did not start')
    return xvfb, ':' + number


# ---------------------------------------------------------------------------------------------------------

# The colour image's name in a bag: dataset_to_bag's (the node's own name), or that of bags it made
# before 2026-12-04, which a replay plugs on with rgb_topic:= and depth_topic:=.
COLOUR_SUFFIXES = ('rgb/image_rect_color', 'rgb/image_raw')


def image_topic_args(bag_path):
    """replay.launch arguments for a bag that records its images under the raw names: none otherwise."""
    import rosbag
    with rosbag.Bag(bag_path) as bag:
        topics = bag.get_type_and_topic_info().topics
    raw = [t for t in topics if t.endswith('/rgb/image_raw')]
    if not raw or any(t.endswith('/rgb/image_rect_color') for t in topics):
        return []
    camera = raw[0][:-len('/rgb/image_raw')]
    return ['rgb_topic:=%s/rgb/image_raw' % camera, 'depth_topic:=%s/depth_registered/image_raw' % camera]


def publish_freenect_frames():
    """The static frames freenect_launch publishes with its defaults: camera_link -> camera_rgb_frame (4.5 cm
    to the right) -> camera_rgb_optical_frame (ROS body axes to optical axes)."""
    import tf2_ros
    from geometry_msgs.msg import TransformStamped
    import rospy
    frames = [('camera_link', 'camera_rgb_frame', (0.0, -0.045, 0.0), (0.0, 0.0, 0.0, 1.0)),
              ('camera_rgb_frame', 'camera_rgb_optical_frame', (0.0, 0.0, 0.0), (-0.5, 0.5, -0.5, 0.5))]
    transforms = []
    for parent, child, t, q in frames:
        tf = TransformStamped()
        tf.header.stamp = rospy.Time(0)
        tf.header.frame_id, tf.child_frame_id = parent, child
        tf.transform.translation.x, tf.transform.translation.y, tf.transform.translation.z = t
        (tf.transform.rotation.x, tf.transform.rotation.y, tf.transform.rotation.z,
         tf.transform.rotation.w) = q
        transforms.append(tf)
    publish_freenect_frames.broadcaster = tf2_ros.StaticTransformBroadcaster()
    publish_freenect_frames.broadcaster.sendTransform(transforms)


class BagPlayer:
    """Plays a bag with its clock, like `rosbag play --clock`, but never more than MAX_AHEAD colour frames
    ahead of what the node reports received (/diagnostics "frames received", every diagnostic_period): on a
    loaded machine the replay slows down instead of the node's subscriber queues dropping frames."""
    MAX_AHEAD = 3
    WAIT_S = 60.0  # for the node to take one frame

    def __init__(self, path, rate, demo, skip=(), rename=None, subscribers=1, prime=None):
        import rosbag
        self.bag = rosbag.Bag(path)
        self.rate = rate
        self.demo = demo
        self.skip = set(skip)  # topics not played (the SLAM's, where a SLAM stand-in runs)
        self.rename = rename or {}  # bag topic -> topic it is played on
        # Play once the colour topic has this many subscribers (the node, and a SLAM that reads the images);
        # until then the first message of `prime` is sent every 0.1 s (a camera_info a SLAM waits for before
        # it subscribes to the images, as a streaming camera's would be).
        self.subscribers = subscribers
        self.prime = prime
        topics = self.bag.get_type_and_topic_info().topics
        self.colour_topics = [t for t in topics if t.endswith(COLOUR_SUFFIXES)]
        if len(self.colour_topics) != 1:
            raise DemoError('the bag has %d colour topics (*/%s), not one' % (
                len(self.colour_topics), ' or */'.join(COLOUR_SUFFIXES)))
        self.frames = self.bag.get_message_count(self.colour_topics)

    def play(self, tick):
        import rospy
        from rosgraph_msgs.msg import Clock
        clock = rospy.Publisher('/clock', Clock, queue_size=10)
        publishers = {}
        for topic, info in self.bag.get_type_and_topic_info().topics.items():
            if topic in self.skip:
                continue
            msg_class = None
            for _, msg, _ in self.bag.read_messages(topics=[topic]):
                msg_class = type(msg)
                break
            publishers[topic] = rospy.Publisher(self.rename.get(topic, topic), msg_class, queue_size=100,
                                                latch=topic.endswith('tf_static'))
        # The node subscribes to the colour topic once it runs: wait for the connection.
        colour = publishers[self.colour_topics[0]]
        primer = None
        if self.prime in publishers:
            for _, primer, _ in self.bag.read_messages(topics=[self.prime]):
                break

        def subscribed():
            if primer is not None:
                publishers[self.prime].publish(primer)
            return colour.get_num_connections() >= self.subscribers
        self.demo.wait_for(subscribed, 60, 'the node (and the SLAM) to subscribe to the bag')
        time.sleep(1.0)  # the other topics' connections
        sent = 0
        first_bag = None
        first_wall = time.time()
        for topic, msg, stamp in self.bag.read_messages():
            if topic in self.skip:
                continue
            tick()
            if first_bag is None:
                first_bag = stamp.to_sec()
            due = first_wall + (stamp.to_sec() - first_bag) / self.rate
            if due > time.time():
                time.sleep(due - time.time())
            if topic == self.colour_topics[0]:
                # The schedule moves by the time waited: after a stall the bag goes on at its rate.
                first_wall += self.wait_for_node(sent - self.MAX_AHEAD, tick)
                sent += 1
            clock.publish(Clock(clock=stamp))
            publishers[topic].publish(msg)
        self.wait_for_node(sent, tick)

    def wait_for_node(self, frames, tick):
        """Until the node reports `frames` received (at most WAIT_S: the end check tells what was lost).
        Returns the seconds waited."""
        start = time.time()
        deadline = start + self.WAIT_S
        while self.demo.received() < frames and time.time() < deadline:
            tick()
            time.sleep(0.01)
        return time.time() - start


class Demo:

    def __init__(self, args):
        self.args = args
        self.processes = []  # (Popen, name), stopped in reverse order
        self.launch_log_path = os.path.join(args.output_dir, 'roslaunch.log')
        self.diagnostics = None
        self.diagnostics_count = 0

    # -- helpers -------------------------------------------------------------------------------------
    def launch_log_tail(self, lines=25):
        try:
            with open(self.launch_log_path, errors='replace') as f:
                return ''.join(f.readlines()[-lines:])
        except OSError:
            return ''

    def check_alive(self):
        if self.launch.poll() is not None:
            raise DemoError('roslaunch exited (status %s)' % self.launch.returncode)
        with open(self.launch_log_path, errors='replace') as f:
            for line in f:
                if 'process has died' in line or 'process has finished cleanly' in line:
                    if 'object_detection' in line:
                        raise DemoError('object_detection_node died: ' + line.strip())
                    if 'orb_slam2_rgbd' in line:
                        raise DemoError('the SLAM (stand-in) died: ' + line.strip())

    def wait_for(self, condition, timeout_s, what):
        deadline = time.time() + timeout_s
        while time.time() < deadline:
            self.check_alive()
            if condition():
                return
            time.sleep(0.25)
        raise DemoError('timed out after %.0f s waiting for %s' % (timeout_s, what))

    def stat(self, key):
        values = {kv.key: kv.value for status in self.diagnostics.status for kv in status.values}
        return float(values.get(key, 'nan'))

    def on_diagnostics(self, msg):
        if any(status.name.startswith('object_detection') for status in msg.status):
            self.diagnostics = msg
            self.diagnostics_count += 1

    def received(self):
        return 0 if self.diagnostics is None else self.stat('frames received')

    def progress(self):
        d = self.diagnostics
        if d is None:
            return 'no diagnostics yet'
        return ('frames %d, keyframes selected %d, processed %d, failed %d, dropped %d, queue %d, objects %d'
                % tuple(self.stat(k) for k in ('frames received', 'keyframes selected', 'keyframes processed',
                                               'keyframes failed', 'keyframes dropped', 'queue length',
                                               'objects')))

    def drained(self):
        if self.diagnostics is None:
            return False
        done = self.stat('keyframes processed') + self.stat('keyframes failed') + \
            self.stat('keyframes dropped')
        return self.stat('queue length') == 0 and done >= self.stat('keyframes selected')

    def check_complete(self, frames):
        """Every frame of the bag received and accepted, every keyframe processed: else the demo fails."""
        problems = []
        lost = frames - self.stat('frames received')
        if lost > 0:
            problems.append('%d of the bag\'s %d frames never reached the node' % (lost, frames))
        for key in ('frames rejected', 'frames lost before the node', 'keyframes dropped', 'keyframes failed',
                    'pose failures'):
            if self.stat(key) > 0:
                problems.append('%s: %d' % (key, self.stat(key)))
        if self.stat('keyframes processed') == 0:
            problems.append('no keyframe was processed')
        if problems:
            raise DemoError('; '.join(problems) + ' (%s; the log says why)' % self.progress())

    def call(self, name, srv_class, *args):
        import rospy
        service = NODE + '/' + name
        try:
            return rospy.ServiceProxy(service, srv_class)(*args)
        except (rospy.ServiceException, rospy.ROSException) as e:
            raise DemoError('%s failed: %s' % (service, e))

    # -- the run ---------------------------------------------------------------------------------------
    def run(self):
        a = self.args
        port = free_port()
        os.environ['ROS_MASTER_URI'] = 'http://localhost:%d' % port
        os.environ.setdefault('ROS_HOME', os.path.join(a.output_dir, 'ros_home'))
        for name in ('ROS_IP', 'ROS_HOSTNAME'):
            os.environ.pop(name, None)
        os.environ['ROS_HOSTNAME'] = 'localhost'

        rviz = not a.no_rviz
        missing = [tool for tool in ('Xvfb', 'rviz', 'import') if shutil.which(tool) is None]
        if rviz and missing:
            log('no rviz screenshot: %s not installed' % ', '.join(missing))
            rviz = False
        env = dict(os.environ)
        if rviz:
            xvfb, display = start_xvfb()
            self.processes.append((xvfb, 'Xvfb'))
            env.update(DISPLAY=display, LIBGL_ALWAYS_SOFTWARE='1')
            self.display = display

        common = ['rviz:=' + ('true' if rviz else 'false'), 'detector:=' + a.detector,
                  'processing_queue_size:=%d' % a.queue_size, 'diagnostic_period:=0.05',
                  'map_directory:=' + os.path.abspath(a.output_dir)]
        if a.launch == 'kinect_orbslam2':
            # The live launch file with the SLAM stand-in in ORB-SLAM2's place (its poses from the trajectory),
            # the driver left out (its frames published here), the bag's clock.
            env['MVOD_ORBSLAM2_STANDIN_TRAJECTORY'] = os.path.abspath(a.slam_trajectory)
            command = ['roslaunch', '-p', str(port), PKG, 'kinect_orbslam2.launch', 'start_kinect:=false',
                       'start_orbslam2:=true', 'orbslam2_package:=' + PKG,
                       'orbslam2_node:=orbslam2_standin.py', 'use_sim_time:=true'] + common
        else:
            command = ['roslaunch', '-p', str(port), PKG, 'replay.launch', 'bag:=' + a.bag, 'play:=false',
                       'pose_source:=topic', 'keyframe_mode:=every_n',
                       'keyframe_every_n:=%d' % a.keyframe_every] + common + image_topic_args(a.bag)
        if a.rviz_config:
            command.append('rviz_config:=' + a.rviz_config)
        if a.paper_method:
            command.append('paper_method:=true')
        if a.model_dir:
            command.append('model_dir:=' + a.model_dir)
        if a.gravity_estimate or a.launch == 'kinect_orbslam2':
            command.append('gravity_source:=estimate')
        else:
            command += ['gravity_source:=param', 'gravity_down:=' + a.gravity_down]
        log('starting the node: ' + ' '.join(command[1:]) + '  (log: %s)' % self.launch_log_path)
        with open(self.launch_log_path, 'w') as launch_log:
            self.launch = subprocess.Popen(command, env=env, stdout=launch_log, stderr=subprocess.STDOUT,
                                           stdin=subprocess.DEVNULL, start_new_session=True)
        self.processes.append((self.launch, 'roslaunch'))

        import rosgraph
        self.wait_for(lambda: rosgraph.is_master_online(), 60, 'the ROS master on port %d' % port)
        import rospy
        rospy.init_node('demo_replay', anonymous=True, disable_signals=True)
        from diagnostic_msgs.msg import DiagnosticArray
        rospy.Subscriber('/diagnostics', DiagnosticArray, self.on_diagnostics)
        master = rosgraph.Master('/demo_replay')

        def has_service():
            try:
                master.lookupService(NODE + '/get_objects')
                return True
            except Exception:
                return False
        if a.launch == 'kinect_orbslam2':
            publish_freenect_frames()  # before the node and the SLAM stand-in take their first frame
        self.wait_for(has_service, 90, 'the node\'s services (model loading, start-up)')
        self.wait_for(lambda: self.diagnostics is not None, 30, '/diagnostics from the node')
        if rviz:
            def rviz_subscribed():
                _, subscribers, _ = master.getSystemState()
                topics = {topic: nodes for topic, nodes in subscribers}
                return any(n.startswith('/rviz') for n in topics.get(NODE + '/markers', []))
            self.wait_for(rviz_subscribed, 90, 'rviz to start')
        log('node ready')

        # -- play ----------------------------------------------------------------------------------------
        start = time.time()
        if a.launch == 'kinect_orbslam2':
            # The SLAM's poses come from the stand-in; freenect names the registered depth image_raw.
            player = BagPlayer(a.bag, a.rate, self, skip=('/tf', '/orb_slam2_rgbd/pose'),
                               rename={'/camera/depth_registered/image_rect': '/camera/depth_registered/image_raw'},
                               subscribers=2, prime='/camera/rgb/camera_info')
        else:
            player = BagPlayer(a.bag, a.rate, self)
        log('playing the bag (%d frames, at most %d ahead of what the node received)'
            % (player.frames, BagPlayer.MAX_AHEAD))
        last_print = [time.time()]
        last_check = [0.0]

        def tick():
            # Called per message and every 10 ms of a wait: the launch log is read twice a second.
            if time.time() - last_check[0] >= 0.5:
                self.check_alive()
                last_check[0] = time.time()
            if time.time() - start > a.timeout:
                raise DemoError('timed out after %.0f s playing the bag' % a.timeout)
            if time.time() - last_print[0] >= 10:
                log('  %3.0f s: %s' % (time.time() - start, self.progress()))
                last_print[0] = time.time()
        player.play(tick)
        log('bag played in %.0f s; waiting for the node to finish its keyframes' % (time.time() - start))

        # -- drain: two diagnostics in a row with an empty queue and every selected keyframe done ----------
        time.sleep(1.0)
        seen = [self.diagnostics_count]
        stable = [0]

        def settled():
            if self.diagnostics_count == seen[0]:
                return False
            seen[0] = self.diagnostics_count
            if time.time() - last_print_box[0] >= 10:
                log('  %3.0f s: %s' % (time.time() - start, self.progress()))
                last_print_box[0] = time.time()
            stable[0] = stable[0] + 1 if self.drained() else 0
            return stable[0] >= 2
        last_print_box = [time.time()]
        self.wait_for(settled, max(30.0, a.timeout - (time.time() - start)), 'the keyframe queue to drain')
        log('done in %.0f s: %s' % (time.time() - start, self.progress()))
        log('time per keyframe (median of the last 100): detector %.1f ms, geometry %.1f ms; from the images '
            'arriving to the objects published %.1f ms' % (
                self.stat('detection median ms'), self.stat('keyframe total median ms'),
                self.stat('latency median ms')))
        self.check_complete(player.frames)

        # -- results -------------------------------------------------------------------------------------
        from std_srvs.srv import Trigger
        from multiview_object_detection.srv import GetObjects, MapFile
        reply = self.call('refine', Trigger)
        log('~refine: ' + reply.message)
        map_path = os.path.join(a.output_dir, 'map.mvmap')  # the node's map folder
        reply = self.call('save_map', MapFile, os.path.abspath(map_path))
        if not reply.success:
            raise DemoError('~save_map: ' + reply.message)
        log('~save_map: ' + reply.message)
        array = self.call('get_objects', GetObjects, '', []).objects
        objects = array.objects
        print_objects(objects)
        if not objects:
            raise DemoError('the node found no objects (%s)' % self.progress())

        if rviz:
            self.screenshot(objects, array.header.frame_id or 'map_gravity_aligned')
        return 0

    def screenshot(self, objects, frame_id):
        """Points rviz's view at the objects, has the node republish its markers, saves a screenshot."""
        import rospy
        from geometry_msgs.msg import TransformStamped
        from std_srvs.srv import Trigger
        from tf2_msgs.msg import TFMessage
        from visualization_msgs.msg import Marker, MarkerArray
        # rviz/demo.rviz orbits the frame demo_focus: on the floor under the objects' middle (the median of
        # their centres in the node's frame), so a map anywhere in the room is in view.
        focus = TransformStamped()
        focus.header.stamp = rospy.Time.now()
        focus.header.frame_id = frame_id
        focus.child_frame_id = 'demo_focus'
        focus.transform.translation.x = median([o.pose.position.x for o in objects])
        focus.transform.translation.y = median([o.pose.position.y for o in objects])
        focus.transform.rotation.w = 1.0
        self.focus_publisher = rospy.Publisher('/tf_static', TFMessage, queue_size=1, latch=True)
        self.focus_publisher.publish(TFMessage(transforms=[focus]))
        # rviz may have dropped some of the node's markers while it was busy (the DELETEs of merged and refined
        # objects among them): clear them all, then have the node republish the map.
        clear = rospy.Publisher(NODE + '/markers', MarkerArray, queue_size=1, latch=True)
        self.wait_for(lambda: clear.get_num_connections() > 0, 10, 'rviz to subscribe to the demo\'s markers')
        marker = Marker(action=3)  # DELETEALL
        marker.header.frame_id = 'map'
        time.sleep(1.0)
        clear.publish(MarkerArray(markers=[marker]))
        time.sleep(1.0)
        self.call('refine', Trigger)  # republishes markers and cloud
        time.sleep(self.args.rviz_wait)
        path = os.path.join(self.args.output_dir, 'rviz.png')
        subprocess.run(['import', '-display', self.display, '-window', 'root', path], check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=60)
        log('rviz screenshot: ' + path)

    def shutdown(self):
        try:
            import rospy
            if rospy.core.is_initialized():
                rospy.signal_shutdown('demo done')
        except ImportError:
            pass
        for process, name in reversed(self.processes):
            stop(process, name)


def median(values):
    values = sorted(values)
    return values[len(values) // 2] if values else 0.0


def print_objects(objects):
    print()
    print('  id  class             prob  obs  centre (m)                 size (m)               yaw (deg)')
    for o in sorted(objects, key=lambda o: o.id):
        p = o.pose.position
        print('%4d  %-16s %5.2f %4d  (%6.2f, %6.2f, %6.2f)   (%5.2f, %5.2f, %5.2f)   %8.1f'
              % (o.id, o.class_name, o.probability, o.observations, p.x, p.y, p.z, o.size.x, o.size.y,
                 o.size.z, math.degrees(o.yaw)))
    print('%d objects' % len(objects))
    print(flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--bag', required=True)
    parser.add_argument('--output-dir', required=True, help='map.mvmap, rviz.png, roslaunch.log')
    parser.add_argument('--detector', default='topic', help='topic (detections in the bag), fastestdet, maskrcnn')
    parser.add_argument('--model-dir', default='')
    parser.add_argument('--gravity-down', default='[0, 0, -1]', help='YAML list, world frame, pointing down')
    parser.add_argument('--gravity-estimate', action='store_true', help='gravity_source:=estimate')
    parser.add_argument('--keyframe-every', type=int, default=10)
    parser.add_argument('--queue-size', type=int, default=200, help='processing_queue_size: keep every keyframe')
    parser.add_argument('--rate', type=float, default=1.0, help='play rate (slower when the node lags)')
    parser.add_argument('--timeout', type=float, default=600, help='seconds for play + processing')
    parser.add_argument('--no-rviz', action='store_true', help='no rviz, no screenshot')
    parser.add_argument('--paper-method', action='store_true', help='the node runs the paper\'s method')
    parser.add_argument('--rviz-config', default='')
    parser.add_argument('--rviz-wait', type=float, default=5.0, help='seconds rviz renders before the shot')
    parser.add_argument('--launch', choices=['replay', 'kinect_orbslam2'], default='replay',
                        help='replay: replay.launch, the bag\'s poses; kinect_orbslam2: the live launch file with '
                        'the ORB-SLAM2 stand-in (test/ros/orbslam2_standin.py) giving the poses of '
                        '--slam-trajectory, gravity estimated, keyframes by motion')
    parser.add_argument('--slam-trajectory', default='', help='kinect_orbslam2: the stand-in\'s TUM trajectory '
                        '(the colour camera in ORB-SLAM2\'s world, stamped as the bag)')
    args = parser.parse_args()
    if args.launch == 'kinect_orbslam2' and not os.path.isfile(args.slam_trajectory):
        parser.error('--launch kinect_orbslam2 needs --slam-trajectory FILE')
    if not os.path.isfile(args.bag):
        parser.error('no bag at ' + args.bag)
    args.bag = os.path.abspath(args.bag)
    os.makedirs(args.output_dir, exist_ok=True)

    demo = Demo(args)
    # SIGTERM (e.g. from make) stops the children too.
    signal.signal(signal.SIGTERM, lambda *_: (_ for _ in ()).throw(KeyboardInterrupt()))
    status = 1
    try:
        status = demo.run()
    except DemoError as e:
        log('FAILED: %s' % e)
        tail = demo.launch_log_tail()
        if tail:
            log('last lines of %s:\n%s' % (demo.launch_log_path, tail))
    except KeyboardInterrupt:
        log('interrupted')
        status = 130
    finally:
        log('stopping the node, rviz and the master')
        demo.shutdown()
    return status


if __name__ == '__main__':
    sys.exit(main())
