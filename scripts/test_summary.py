#!/usr/bin/python3
"""Counts test cases in catkin's JUnit XML results and prints 'N passed, N failed, N skipped'.

Exit status 1 when a test failed or errored, or when no result file exists (a build or runner problem)."""
import glob
import os
import sys
import xml.etree.ElementTree as ET


def main():
    results_dir = sys.argv[1]
    files = sorted(glob.glob(os.path.join(results_dir, '**', '*.xml'), recursive=True))
    passed = failed = skipped = 0
    failed_names = []
    for path in files:
        try:
            root = ET.parse(path).getroot()
        except ET.ParseError as err:
            print('unreadable result file %s: %s' % (path, err))
            failed += 1
            failed_names.append(os.path.basename(path))
            continue
        for case in root.iter('testcase'):
            name = '%s.%s' % (case.get('classname', ''), case.get('name', ''))
            if case.find('failure') is not None or case.find('error') is not None:
                failed += 1
                failed_names.append(name)
            elif case.find('skipped') is not None or case.get('status') == 'notrun':
                skipped += 1
            else:
                passed += 1
    for name in failed_names:
        print('FAILED: %s' % name)
    if not files:
        print('no test result files under %s' % results_dir)
        failed += 1
    print('%d passed, %d failed, %d skipped' % (passed, failed, skipped))
    return 1 if failed else 0


if __name__ == '__main__':
    sys.exit(main())
