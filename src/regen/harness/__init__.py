"""Policy testing shared by every domain: the `regen test` command, test cases, reports and
JUnit XML. It names no domain: a domain plugs in through its backend's policy harness.
"""
