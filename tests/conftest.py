from __future__ import annotations


def pytest_configure(config: object) -> None:
    """Builds the tests start keep their generation cache (uros's, normally ~/.cache/uros/gen) in
    a folder of this run's own, unless the caller chose one: a test run neither reads nor fills
    the user's."""
    import os
    import tempfile

    if not os.environ.get("UROS_GEN_CACHE_DIR"):
        os.environ["UROS_GEN_CACHE_DIR"] = tempfile.mkdtemp(prefix="uros-test-gen-cache-")
