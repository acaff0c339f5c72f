"""numba's cache keyed by the physics and kernel sources (``vines_stoch.cache``): an edited
formula that a cached function inlines is compiled afresh, never run stale."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

from vines_stoch import cache

#: Stored energy of a primary with one linear absorber (``kernels.common.stored_energy``
#: inlines ``physics.spring_damper_energy``), printed in full.
SCRIPT = r'''
import numpy as np
from vines_stoch.kernels.common import stored_energy
x, v = np.array([0.1, 0.3]), np.array([0.0, 0.0])
rows = np.zeros((1, 10)); rows[0, 0] = 2.0
print(repr(stored_energy(x, v, np.array([1.0, 0.1]), 1, np.array([1.0]), np.zeros(1, np.int64),
                         np.zeros(1, np.int64), rows)))
'''


def _run(root: Path, numba_cache: Path) -> float:
    env = {**os.environ, "PYTHONPATH": str(root), "NUMBA_CACHE_DIR": str(numba_cache)}
    done = subprocess.run([sys.executable, "-c", SCRIPT], cwd=root, env=env, capture_output=True, text=True,
                          check=True)
    return float(done.stdout)


def test_an_edited_formula_is_compiled_afresh(tmp_path):
    root = tmp_path / "tree"
    shutil.copytree(cache.PACKAGE, root / "vines_stoch", ignore=shutil.ignore_patterns("__pycache__"))
    numba_cache = tmp_path / "numba"
    before = _run(root, numba_cache)
    assert before == _run(root, numba_cache)  # (now from the cache)
    physics = root / "vines_stoch" / "physics.py"
    text = physics.read_text()
    start = text.index("def spring_damper_energy")
    body = text.index("return", start)
    physics.write_text(text[:body] + "return 2.0 * " + text[body + len("return "):])
    after = _run(root, numba_cache)
    # the absorber spring's energy doubled: 0.5 k u^2 = 0.04 more
    assert after != before and abs(after - before - 0.5 * 2.0 * 0.2**2) < 1e-12
    folders = {p.name for p in numba_cache.rglob("vines-stoch-*")}
    assert len(folders) == 2, folders


def test_the_digest_follows_every_source(tmp_path):
    root = tmp_path / "vines_stoch"
    shutil.copytree(cache.PACKAGE, root, ignore=shutil.ignore_patterns("__pycache__"))
    first = cache.digest(root)
    assert first == cache.digest(cache.PACKAGE)
    for name in ("physics.py", "kernels/loads.py", "kernels/common.py"):
        path = root / name
        path.write_text(path.read_text() + "\n# edited\n")
        assert cache.digest(root) != first, name
        first = cache.digest(root)


def test_a_package_in_a_zip_archive_keeps_numba_s_own_locations(tmp_path):
    """Sources that are not files (a zip archive: nothing to edit) are not hashed."""
    import zipfile

    archive = tmp_path / "vs.zip"
    with zipfile.ZipFile(archive, "w") as z:
        for f in cache.PACKAGE.rglob("*.py"):
            z.write(f, f.relative_to(cache.PACKAGE.parent))
    env = {**os.environ, "PYTHONPATH": str(archive)}
    done = subprocess.run([sys.executable, "-c", "import vines_stoch.physics, vines_stoch.cache as c; "
                           "print(repr(c.key_by_sources()), c.PACKAGE)"], cwd=tmp_path, env=env,
                          capture_output=True, text=True, check=True)
    assert done.stdout.startswith("'' ") and "vs.zip" in done.stdout
