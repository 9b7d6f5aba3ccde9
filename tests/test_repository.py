"""The repository stands alone: a clone with nothing beside it has everything the tests,
the studies and ``make run`` read, and no tracked file points outside the checkout."""
from __future__ import annotations

import re
import subprocess

import pytest

from conftest import DATA, REPO

# A path that leaves the checkout: the steering folder beside the repository, a machine's own
# folders, or a climb out of the repository from a file's location.
OUTSIDE = re.compile(r"\.\./shared|\bshared/(anchors|cases|thesis)\b|/work/|/root/|/home/\w+/"
                     r"|parents\[[2-9]\]\s*/\s*[\"']shared"
                     r"|[\"']shared[\"']\s*/\s*[\"'](anchors|cases|thesis)")


def tracked_files() -> list[str]:
    out = subprocess.run(["git", "ls-files", "-z"], cwd=REPO, capture_output=True, check=True)
    return [p for p in out.stdout.decode().split("\0") if p]


def test_no_tracked_file_refers_outside_the_checkout():
    try:
        files = tracked_files()
    except (OSError, subprocess.CalledProcessError) as exc:
        pytest.fail(f"git ls-files failed in {REPO}: {exc}")
    assert len(files) > 50
    me = "tests/test_repository.py"
    hits = []
    for name in files:
        path = REPO / name
        if name == me or not path.is_file():
            continue
        try:
            text = path.read_text(encoding="utf-8")
        except UnicodeDecodeError:  # binary data (.mat, .png)
            continue
        for n, line in enumerate(text.splitlines(), 1):
            if OUTSIDE.search(line):
                hits.append(f"{name}:{n}: {line.strip()[:120]}")
    assert not hits, "paths outside the checkout:\n" + "\n".join(hits)


def test_the_pattern_catches_what_it_is_for():
    for bad in ('DATA = Path(__file__).resolve().parents[2] / "shared" / "anchors"',
                "see ../shared/anchors/modelica/README.md", '"/work/shared/anchors/data/emps/DATA_EMPS.mat"',
                "python -m x --data-dir shared/cases/p01",
                'd = parent / "shared" / "anchors" / "data" / "emps"'):
        assert OUTSIDE.search(bad), bad
    for good in ('DATA = REPO / "data" / "emps"', "index layout shared by the packer", "data/cases/p01/data.csv"):
        assert not OUTSIDE.search(good), good


@pytest.mark.parametrize("folder, needles", [
    ("modelica", ["BSD 3-Clause", "MAP-LIB_ReferenceResults", "sha256"]),
    ("emps", ["Janot", "hal-02178709", "sha256"]),
    ("cases", ["independent", "truth.yaml"]),
])
def test_each_data_folder_says_where_it_comes_from(folder, needles):
    readme = (DATA / folder / "README.md").read_text()
    for needle in needles:
        assert needle in readme, f"data/{folder}/README.md lacks {needle!r}"


def test_the_data_the_tests_and_studies_read_are_tracked():
    files = set(tracked_files())
    wanted = [f"data/modelica/{n}.csv" for n in ("Rotational_Examples_Backlash", "Rotational_Examples_Friction",
                                                "Translational_Examples_ElastoGap", "Translational_Examples_Friction")]
    wanted += ["data/emps/DATA_EMPS.mat", "data/emps/DATA_EMPS_PULSES.mat"]
    wanted += [f"data/cases/p0{i}/{n}" for i in range(1, 5) for n in ("data.csv", "nominal.yaml", "truth.yaml")]
    missing = [w for w in wanted if w not in files]
    assert not missing, f"not tracked by git: {missing}"
