"""The physics source hash is written once (gearbench.physics_hash) and keys both
numba's cache folder (gearbench/__init__.py) and a sweep's resume keys (sweep.py)."""
from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import gearbench
import gearbench.sweep as sw
from gearbench.physics_hash import PACKAGE, physics_digest, physics_files

REPO = Path(__file__).resolve().parents[1]


def _copy(tmp_path: Path) -> Path:
    pkg = tmp_path / "gearbench"
    shutil.copytree(PACKAGE, pkg, ignore=shutil.ignore_patterns("__pycache__"))
    return pkg


def test_the_file_set_is_every_module_under_plant_control_solver_plus_layout_and_simulate():
    expected = {"layout.py", "simulate.py"}
    for folder in ("plant", "control", "solver"):
        expected |= {str(p.relative_to(PACKAGE)) for p in (PACKAGE / folder).rglob("*.py")}
    got = [str(p.relative_to(PACKAGE)) for p in physics_files()]
    assert set(got) == expected and got == sorted(got)
    assert "plant/effects/backlash.py" in got and "control/laws.py" in got


def test_cache_folder_and_sweep_keys_use_the_one_digest():
    assert sw.physics_digest is physics_digest
    assert Path(gearbench._cache_dir()).name == f"numba-{physics_digest()}"


def test_editing_a_physics_file_changes_the_digest_and_other_files_do_not(tmp_path):
    pkg = _copy(tmp_path)
    before = physics_digest(pkg)
    assert before == physics_digest()  # a copy hashes as the package
    (pkg / "cli.py").write_text((pkg / "cli.py").read_text() + "\n# not physics\n")
    (pkg / "report" / "tables.py").write_text("# not physics\n")
    assert physics_digest(pkg) == before
    for rel in ("simulate.py", "layout.py", "plant/effects/backlash.py", "control/laws.py", "solver/events.py"):
        path = pkg / rel
        text = path.read_text()
        path.write_text(text + "\n# edited\n")
        assert physics_digest(pkg) != before, rel
        path.write_text(text)
    assert physics_digest(pkg) == before
    (pkg / "plant" / "effects" / "backlash.py").rename(pkg / "plant" / "effects" / "backlash2.py")
    assert physics_digest(pkg) != before  # a renamed file counts


def test_sweep_keys_follow_the_digest(tmp_path, monkeypatch):
    exp = tmp_path / "mini.yaml"
    exp.write_text(f"""
name: mini
plant: {REPO / "experiments" / "plants" / "thesis_gear.yaml"}
duration_s: 0.5
profiles: [profile2]
controllers:
  - {{kind: p, kp: 50}}
shift: [off]
""")
    params = sw.parse_params(["controllers[0].kp=50"])
    key = sw.plan_sweep(exp, params).points[0].key
    assert sw.plan_sweep(exp, params).points[0].key == key
    monkeypatch.setattr(sw, "physics_digest", lambda: "0" * 16)
    assert sw.plan_sweep(exp, params).points[0].key != key


def test_import_gearbench_stays_cheap():
    code = "import sys, gearbench; print(sorted(m for m in ('numba', 'numpy', 'pandas') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={"PYTHONPATH": str(REPO), "PATH": ""}).stdout
    assert out.strip() == "[]"
