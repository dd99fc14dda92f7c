"""Validates a JUnit XML file against tests/data/junit.xsd and checks its
counts: python3 check_junit.py FILE TESTS FAILURES XSD [SKIPPED]."""
import sys
import xml.etree.ElementTree as ET

import xmlschema

path, tests, failures = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
schema = xmlschema.XMLSchema(sys.argv[4])
schema.validate(path)  # raises with the line and the rule broken
root = ET.parse(path).getroot()
cases = root.findall("./testsuite/testcase")
failed = [c for c in cases if c.find("failure") is not None]
assert len(cases) == tests, f"{len(cases)} testcases, expected {tests}"
assert len(failed) == failures, f"{len(failed)} failures, expected {failures}"
assert int(root.get("tests")) == tests and int(root.get("failures")) == failures
if len(sys.argv) > 5:
    skipped = [c for c in cases if c.find("skipped") is not None]
    assert len(skipped) == int(sys.argv[5]), f"{len(skipped)} skipped, expected {sys.argv[5]}"
    for c in skipped:
        assert c.find("skipped").get("message"), "a skipped run without its reason"
for c in failed:
    assert c.find("failure").get("message"), "a failure without a message"
print("junit ok", len(cases), len(failed))
