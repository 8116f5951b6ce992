#!/usr/bin/python3
"""`make test-sanitize`, last step: finds every sanitizer report of the run, prints it, and fails if there is one.

  test/sanitize/check_reports.py LOG_DIR TEST_LOG

Where the reports are (gcc links ASan and UBSan as two runtimes, test/sanitize/README.md):
  - ASan and LSan write to LOG_DIR/asan.<pid> (ASAN_OPTIONS log_path), one file per process that reported;
  - UBSan writes to the process's stderr: TEST_LOG (catkin's output of the gtests and of the rostests, whose
    nodes keep stderr on the console) and the ROS log files under LOG_DIR (ROS_LOG_DIR).
Each distinct report (kind and place) is printed once in full, with how often it came; then one line per
report: its kind, where, and the first stack frame in this repository. Exit status 1 when there is any.
"""
import collections
import os
import re
import sys

UBSAN = re.compile(r'^(?P<where>\S+:\d+:\d+): runtime error: (?P<what>.*)$')
ASAN = re.compile(r'^==\d+==ERROR: (?P<what>(AddressSanitizer|LeakSanitizer): .*)$')
FRAME = re.compile(r'^\s+#\d+ 0x[0-9a-f]+ in (?P<function>.*?) (?P<where>\S+)$')
ANSI = re.compile(r'\x1b\[[0-9;]*m')
# Frames of this repository: its files, named relative to the build folder (../../../../src/...) or absolute.
# The headers catkin generates into devel/include (messages, dynamic_reconfigure) are upstream templates' code.
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def own_frame(where):
    path = re.sub(r':\d+(:\d+)?$', '', where)
    if path.startswith(ROOT + '/'):
        path = path[len(ROOT) + 1:]
    elif path.startswith('/'):
        return False
    path = re.sub(r'^(\.\./)+', '', path)
    return not path.startswith('build/') and os.path.isfile(os.path.join(ROOT, path))


def short(where):
    where = re.sub(r'^(\.\./)+', '', where)
    return where[len(ROOT) + 1:] if where.startswith(ROOT + '/') else where


def ubsan_reports(path):
    """(key, text) of each UBSan report in a file: the 'runtime error' line and its stack."""
    with open(path, errors='replace') as f:
        lines = [ANSI.sub('', line.rstrip('\n')) for line in f]
    reports = []
    for i, line in enumerate(lines):
        m = UBSAN.search(line)
        if not m:
            continue
        text = [line[m.start():]]
        for following in lines[i + 1:]:
            if FRAME.match(following):
                text.append(following)
            elif len(text) > 1 or not following.strip() or UBSAN.search(following):
                break
        # One key per place and kind: the values in the message ("load of value 48") vary.
        kind = re.sub(r'-?\b\d+(\.\d+)?(e[+-]?\d+)?\b', 'N', m.group('what'))
        reports.append(('UBSan: %s at %s' % (kind, short(m.group('where'))), '\n'.join(text)))
    return reports


def asan_reports(path):
    """(key, text) of the report(s) in an ASan/LSan log file (the whole file is one process's output)."""
    with open(path, errors='replace') as f:
        text = f.read()
    reports = []
    for block in re.split(r'(?m)^(?===\d+==ERROR: )', text):
        m = ASAN.search(block.splitlines()[0]) if block.strip() else None
        if not m:
            continue
        frames = [FRAME.match(line) for line in block.splitlines()]
        own = [f.group('where') for f in frames if f and own_frame(f.group('where'))]
        what = re.sub(r' on (address|unknown address) 0x[0-9a-f]+.*', '', m.group('what'))
        key = '%s at %s' % (what, short(own[0]) if own else 'no frame of this repository')
        if what.startswith('LeakSanitizer'):
            leaks = re.findall(r'(?m)^(Direct|Indirect) leak of (\d+) byte', block)
            key = 'LeakSanitizer: %d leak(s), %d bytes; first frame here: %s' % (
                len(leaks), sum(int(n) for _, n in leaks), short(own[0]) if own else 'none')
        reports.append((key, block.rstrip()))
    return reports


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    log_dir, test_log = sys.argv[1], sys.argv[2]
    found = collections.OrderedDict()  # key -> [count, text, sources]

    def add(key, text, source):
        entry = found.setdefault(key, [0, text, set()])
        entry[0] += 1
        entry[2].add(source)

    files = [test_log] if os.path.isfile(test_log) else []
    for folder, _, names in os.walk(log_dir):
        files += [os.path.join(folder, name) for name in sorted(names)]
    for path in files:
        source = os.path.relpath(path, ROOT) if path.startswith(ROOT) else path
        if re.match(r'asan\.\d+$', os.path.basename(path)):
            for key, text in asan_reports(path):
                add(key, text, source)
        for key, text in ubsan_reports(path):
            add(key, text, source)

    if not found:
        print('sanitizers: 0 reports')
        return 0
    for key, (count, text, sources) in found.items():
        print('===================== %s  (%d time%s; in %s)' % (key, count, 's' if count > 1 else '',
                                                             ', '.join(sorted(sources))))
        print(text)
    print()
    print('sanitizer reports: %d distinct' % len(found))
    for key, (count, text, _) in found.items():
        frames = [FRAME.match(line) for line in text.splitlines()]
        own = [f for f in frames if f and own_frame(f.group('where'))]
        first = ('; first frame here: %s in %s' % (short(own[0].group('where')), own[0].group('function')[:80])
                 if own and not key.startswith('LeakSanitizer') else '')
        print('  %dx %s%s' % (count, key, first))
    return 1


if __name__ == '__main__':
    sys.exit(main())
