#!/usr/bin/python3
"""Counts test cases in catkin's JUnit XML results and prints 'N passed, N failed, N skipped'.

Each failed test is named with the first lines of its failure message, so that a CI log that keeps only the
end of the output still says why it failed. Exit status 1 when a test failed or errored, or when no result
file exists (a build or runner problem)."""
import glob
import os
import sys
import xml.etree.ElementTree as ET


MAX_FAILURE_LINES = 25


def failure_text(problems):
    """The first MAX_FAILURE_LINES lines of a test case's <failure> and <error> elements (gtest writes one per
    failed assertion, its message twice: as the attribute and as the text; a text that repeats its message is
    printed once)."""
    lines = []
    for element in problems:
        message = element.get('message', '').strip()
        text = (element.text or '').strip()
        for block in [message] + ([text] if text and text != message else []):
            lines.extend(line.rstrip() for line in block.splitlines() if line.strip())
    if len(lines) > MAX_FAILURE_LINES:
        more = len(lines) - MAX_FAILURE_LINES
        lines = lines[:MAX_FAILURE_LINES] + ['... (%d more lines in the result file)' % more]
    return lines


def main():
    results_dir = sys.argv[1]
    files = sorted(glob.glob(os.path.join(results_dir, '**', '*.xml'), recursive=True))
    passed = failed = skipped = 0
    failed_names = []
    failure_texts = []
    for path in files:
        try:
            root = ET.parse(path).getroot()
        except ET.ParseError as err:
            print('unreadable result file %s: %s' % (path, err))
            failed += 1
            failed_names.append(os.path.basename(path))
            failure_texts.append([])
            continue
        for case in root.iter('testcase'):
            name = '%s.%s' % (case.get('classname', ''), case.get('name', ''))
            problems = case.findall('failure') + case.findall('error')
            if problems:
                failed += 1
                failed_names.append(name)
                failure_texts.append(failure_text(problems))
            elif case.find('skipped') is not None or case.get('status') == 'notrun':
                skipped += 1
            else:
                passed += 1
    for index, name in enumerate(failed_names):
        print('FAILED: %s' % name)
        for line in failure_texts[index]:
            print('    %s' % line)
    if not files:
        print('no test result files under %s' % results_dir)
        failed += 1
    print('%d passed, %d failed, %d skipped' % (passed, failed, skipped))
    return 1 if failed else 0


if __name__ == '__main__':
    sys.exit(main())
