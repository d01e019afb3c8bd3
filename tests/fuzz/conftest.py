"""The fuzzer's runner (a fork server) and its seed inputs, made once for tests/fuzz."""
from __future__ import annotations

import pytest
from fuzzing import Runner, Seeds


@pytest.fixture(scope="session")
def runner():
    with Runner() as runner:
        yield runner


@pytest.fixture(scope="session")
def seeds(runner, tmp_path_factory):
    return Seeds(tmp_path_factory.mktemp("seeds"), runner)
