#!/usr/bin/python3
"""Headless rviz with rviz/objects.rviz while object_detection_node maps the synthetic scene.

Starts Xvfb on a free display and rviz on it, has rviz_test_publisher play one lap of the synthetic scene into
the node, takes a screenshot (ImageMagick `import -window root`) and checks its pixels: the colours of the
node's box markers must cover the 3D view. After ~reset a second screenshot must have (almost) none of them:
the deleted markers are gone. The screenshots are saved next to the test results (or in $ROS_HOME) and their
paths printed. Skips with a message when Xvfb, rviz or ImageMagick are missing.
"""
import os
import shutil
import subprocess
import sys
import time
import unittest

import rosgraph.masterapi
import rospkg
import rospy
import rostest
from std_msgs.msg import String

PKG = 'multiview_object_detection'
SCREEN = (1280, 1024)
BACKGROUND = (48, 48, 48)  # rviz's background colour in objects.rviz
COLOR_TOLERANCE = 12       # per channel, for anti-aliasing and blending
MIN_BOX_PIXELS = 300       # pixels in box colours expected in the 3D view (a 0.02 m line is 1-3 px wide)


def output_dir():
    """Where rostest writes this test's results (from --gtest_output), else $ROS_HOME, else ~/.ros."""
    for arg in sys.argv:
        if arg.startswith('--gtest_output=xml:'):
            return os.path.dirname(os.path.abspath(arg[len('--gtest_output=xml:'):]))
    return os.environ.get('ROS_HOME', os.path.join(os.path.expanduser('~'), '.ros'))


def read_ppm(data):
    """(width, height, bytes) of a binary PPM (P6, maxval 255)."""
    fields = []
    pos = 0
    while len(fields) < 4:
        while data[pos:pos + 1].isspace():
            pos += 1
        if data[pos:pos + 1] == b'#':
            pos = data.index(b'\n', pos) + 1
            continue
        end = pos
        while not data[end:end + 1].isspace():
            end += 1
        fields.append(data[pos:end])
        pos = end
    if fields[0] != b'P6' or int(fields[3]) != 255:
        raise ValueError('not an 8-bit binary PPM')
    width, height = int(fields[1]), int(fields[2])
    pixels = data[pos + 1:pos + 1 + 3 * width * height]
    return width, height, pixels


def load_rgb(png_path):
    ppm = subprocess.run(['convert', png_path, '-depth', '8', 'ppm:-'], check=True,
                         stdout=subprocess.PIPE).stdout
    return read_ppm(ppm)


def view_region(width, height, pixels):
    """(x0, y0, x1, y1) of rviz's 3D view: the columns and rows mostly in its background colour (other
    panels have at most a colour swatch of it)."""
    step = 2
    columns = [0] * width
    rows = [0] * height
    for y in range(0, height, step):
        row = pixels[3 * width * y:3 * width * (y + 1)]
        for x in range(0, width, step):
            if row[3 * x] == BACKGROUND[0] and row[3 * x + 1] == BACKGROUND[1] and row[3 * x + 2] == BACKGROUND[2]:
                columns[x] += 1
                rows[y] += 1
    xs = [x for x in range(width) if columns[x] > 0.2 * height / step]
    ys = [y for y in range(height) if rows[y] > 0.2 * width / step]
    if not xs or not ys:
        return None
    return xs[0], ys[0], xs[-1], ys[-1]


def count_colors(width, pixels, region, colors):
    """Pixels of each colour (within COLOR_TOLERANCE) inside region."""
    counts = {c: 0 for c in colors}
    x0, y0, x1, y1 = region
    for y in range(y0, y1 + 1):
        row = pixels[3 * width * y:3 * width * (y + 1)]
        for x in range(x0, x1 + 1):
            r, g, b = row[3 * x], row[3 * x + 1], row[3 * x + 2]
            if max(r, g, b) - min(r, g, b) < 40:
                continue  # grey: background, grid, text
            for c in colors:
                if abs(r - c[0]) <= COLOR_TOLERANCE and abs(g - c[1]) <= COLOR_TOLERANCE and \
                        abs(b - c[2]) <= COLOR_TOLERANCE:
                    counts[c] += 1
                    break
    return counts


def parse_colors(text):
    return [tuple(int(v) for v in item.split(',')) for item in text.split(';') if item]


class RvizScreenshotTest(unittest.TestCase):

    def setUp(self):
        self.processes = []

    def tearDown(self):
        for process in reversed(self.processes):
            if process.poll() is None:
                process.terminate()
                try:
                    process.wait(timeout=10)
                except subprocess.TimeoutExpired:
                    process.kill()

    def start_xvfb(self):
        """Xvfb on a free display (-displayfd picks it); returns ':N'."""
        read_fd, write_fd = os.pipe()
        xvfb = subprocess.Popen(['Xvfb', '-displayfd', str(write_fd), '-screen', '0',
                                 '%dx%dx24' % SCREEN, '-nolisten', 'tcp', '-noreset'],
                                pass_fds=(write_fd,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        self.processes.append(xvfb)
        os.close(write_fd)
        with os.fdopen(read_fd) as pipe:
            number = pipe.readline().strip()
        self.assertTrue(number, 'Xvfb did not start')
        return ':' + number

    def wait_for(self, condition, timeout_s, what):
        deadline = time.time() + timeout_s
        while time.time() < deadline and not rospy.is_shutdown():
            if condition():
                return
            time.sleep(0.2)
        self.fail('timed out after %.0f s waiting for %s' % (timeout_s, what))

    def rviz_subscribed(self):
        _, subscribers, _ = rosgraph.masterapi.Master('/rviz_screenshot_test').getSystemState()
        topics = {topic: nodes for topic, nodes in subscribers}
        return all(any(node.startswith('/rviz') for node in topics.get(topic, []))
                   for topic in ('/object_detection/markers', '/object_detection/detections_image'))

    def screenshot(self, display, path):
        subprocess.run(['import', '-display', display, '-window', 'root', path], check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=30)
        print('rviz screenshot: %s' % path)
        return load_rgb(path)

    def test_boxes_visible_in_rviz(self):
        missing = [tool for tool in ('Xvfb', 'rviz', 'import', 'convert') if shutil.which(tool) is None]
        if missing:
            print('SKIPPED: rviz screenshot test needs %s' % ', '.join(missing))
            self.skipTest('missing ' + ', '.join(missing))

        status = {'text': ''}
        rospy.Subscriber('/rviz_test/status', String, lambda msg: status.update(text=msg.data))
        command = rospy.Publisher('/rviz_test/command', String, queue_size=10, latch=True)

        display = self.start_xvfb()
        config = os.path.join(rospkg.RosPack().get_path(PKG), 'rviz', 'objects.rviz')
        env = dict(os.environ, DISPLAY=display, LIBGL_ALWAYS_SOFTWARE='1')
        rviz_log = open(os.path.join(output_dir(), 'rviz_screenshot_rviz.log'), 'w')
        self.processes.append(subprocess.Popen(['rviz', '-d', config], env=env, stdout=rviz_log,
                                               stderr=subprocess.STDOUT))
        self.wait_for(self.rviz_subscribed, 90, 'rviz to subscribe to the markers and the detections image')
        self.wait_for(lambda: command.get_num_connections() > 0, 30, 'rviz_test_publisher')

        command.publish(String(data='start'))
        self.wait_for(lambda: status['text'].startswith(('published', 'error')), 150,
                      'the synthetic lap to be mapped')
        self.assertTrue(status['text'].startswith('published'), status['text'])
        fields = dict(item.split('=', 1) for item in status['text'].split() if '=' in item)
        boxes = parse_colors(fields.get('boxes', ''))
        clouds = parse_colors(fields.get('clouds', ''))
        self.assertGreaterEqual(len(boxes), 3, 'too few box colours: ' + status['text'])
        # Only colours no object cloud has, so the pixels counted are the boxes' edges.
        distinct = [c for c in boxes
                    if all(max(abs(c[i] - d[i]) for i in range(3)) > 3 * COLOR_TOLERANCE for d in clouds)]
        self.assertGreaterEqual(len(distinct), 2, 'box colours all close to cloud colours: ' + status['text'])

        time.sleep(3.0)  # a few rendered frames
        directory = output_dir()
        width, height, pixels = self.screenshot(display, os.path.join(directory, 'rviz_screenshot_objects.png'))
        region = view_region(width, height, pixels)
        self.assertIsNotNone(region, 'no 3D view (background %s) in the screenshot' % (BACKGROUND,))
        counts = count_colors(width, pixels, region, distinct)
        print('3D view %s; box colour pixels: %s' % (region, counts))
        self.assertGreaterEqual(sum(counts.values()), MIN_BOX_PIXELS, 'boxes not visible: %s' % counts)
        self.assertGreaterEqual(sum(1 for n in counts.values() if n >= 20), 2,
                                'fewer than two box colours visible: %s' % counts)

        # ~reset deletes the markers: their colours leave the view.
        command.publish(String(data='reset'))
        self.wait_for(lambda: status['text'].startswith('reset'), 30, '~reset')
        self.assertEqual(status['text'], 'reset 0')
        time.sleep(2.0)
        width, height, pixels = self.screenshot(display,
                                                os.path.join(directory, 'rviz_screenshot_after_reset.png'))
        after = count_colors(width, pixels, region, distinct)
        print('after ~reset, box colour pixels: %s' % after)
        self.assertLess(sum(after.values()), 0.1 * sum(counts.values()), 'boxes still shown: %s' % after)


if __name__ == '__main__':
    rospy.init_node('rviz_screenshot_test')
    rostest.rosrun(PKG, 'rviz_screenshot', RvizScreenshotTest)
