"""diffosi harness: the Python side (reference-engine adapters, replay, tests)."""
