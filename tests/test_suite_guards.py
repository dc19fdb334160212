"""The test suite's own guards: a skipped test or module fails the run."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent


@pytest.mark.parametrize(
    "body",
    [
        pytest.param("import pytest\npytest.importorskip('no_such_module_here')\n\ndef test_x():\n    pass\n", id="at-collection"),
        pytest.param("import pytest\n\ndef test_x():\n    pytest.skip('missing')\n", id="in-a-test"),
    ],
)
def test_a_skip_fails_the_run(tmp_path: Path, body: str) -> None:
    shutil.copy(HERE / "conftest.py", tmp_path / "conftest.py")
    (tmp_path / "test_skips.py").write_text("from __future__ import annotations\n" + body)
    run = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(tmp_path)],
        cwd=tmp_path, capture_output=True, text=True, timeout=120,
        env={k: v for k, v in os.environ.items() if k != "STARID_ALLOW_SKIPS"},
    )
    assert run.returncode == 1, run.stdout + run.stderr
    assert "skipped (set STARID_ALLOW_SKIPS=1 to allow)" in run.stdout
