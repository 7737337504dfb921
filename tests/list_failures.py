#!/usr/bin/env python3
"""Names every failed test case in JUnit XML files, one line each with the first line of its message.

Printed last by run_all.sh: CI shows only the end of the output, and a failure must be identifiable from it.
Usage: list_failures.py XML_OR_DIR [XML_OR_DIR ...]; exits 0 whether or not anything failed.
"""
import glob
import os
import sys
import xml.etree.ElementTree as ElementTree

MESSAGE_CHARS = 160  # enough for an assertion's first line, short enough for a CI log's tail


def junit_files(paths):
    for path in paths:
        if os.path.isdir(path):
            yield from sorted(glob.glob(os.path.join(path, "**", "*.xml"), recursive=True))
        elif os.path.exists(path):
            yield path


def failures(xml_path):
    """(test case name, first line of its failure or error) for each failed case of one file."""
    try:
        root = ElementTree.parse(xml_path).getroot()
    except ElementTree.ParseError as error:
        yield "(the whole file)", "unreadable result file: %s" % error
        return
    for case in root.iter("testcase"):
        for outcome in ("failure", "error"):
            element = case.find(outcome)
            if element is not None:
                text = (element.get("message") or element.text or outcome).strip()
                name = ".".join(filter(None, (case.get("classname"), case.get("name"))))
                yield name, text.splitlines()[0][:MESSAGE_CHARS] if text else outcome


def main(argv):
    found = [(os.path.basename(path), name, message)
             for path in junit_files(argv[1:]) for name, message in failures(path)]
    if found:
        print("== failed tests (%d)" % len(found))
        for file_name, name, message in found:
            print("FAILED %s: %s: %s" % (file_name, name, message))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
