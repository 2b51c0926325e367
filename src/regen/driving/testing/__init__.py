"""Policy testing in driving: built-in policies, the closed policy loop, test cases and
reports, parameter variants, the adversarial search and failure pictures.

Imports: every lower driving stage (world up to render) and the shared harness.
"""
