"""Table I regenerated: the thesis's five findings hold, and the committed results match."""
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from gearbench.experiment.files import load_experiment
from gearbench.report import tables
from gearbench.runner import run_experiment

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def table() -> pd.DataFrame:
    exp = load_experiment(REPO / "experiments" / "table1.yaml")
    records = run_experiment(exp)
    assert all(r.result.ok for r in records), [r.result.meta.get("message") for r in records]
    return tables.compare(tables.records_frame(records), tables.read_reference(exp.reference))


def iae(table, profile, shift):
    rows = table[(table["profile"] == profile) & (table["shift"] == shift)]
    assert len(rows) == 5
    return rows.set_index(rows.controller + rows.kp.fillna(0).astype(str))["iae_deg_s"]


def test_thirty_cells(table):
    assert len(table) == 30
    assert list(tables.TABLE1_COLUMNS) == ["profile", "controller", "kp", "shift", "iae_deg_s",
                                          "thesis_iae_deg_s", "ratio"]


@pytest.mark.parametrize("profile", [1, 2])
def test_finding1_controllers_alike_without_shift(table, profile):
    v = iae(table, profile, "off")
    assert v.max() / v.min() <= 1.10, v.to_dict()


@pytest.mark.parametrize("profile", [1, 2])
def test_finding2_shift_cuts_error_fourfold(table, profile):
    cut = iae(table, profile, "off") / iae(table, profile, "on")
    assert (cut >= 4.0).all(), cut.to_dict()


def test_finding3_shift_helps_less_than_twofold_on_profile3(table):
    cut = iae(table, 3, "off") / iae(table, 3, "on")
    assert (cut < 2.0).all() and (cut > 1.0).all(), cut.to_dict()


def test_finding4_error_grows_with_profile(table):
    p1, p2, p3 = (iae(table, p, "off") for p in (1, 2, 3))
    assert ((p1 < p2) & (p2 < p3)).all(), (p1.to_dict(), p2.to_dict(), p3.to_dict())


def test_finding5_every_cell_within_factor_two_of_thesis(table):
    r = table["ratio"]
    assert r.notna().all()
    assert ((r >= 0.5) & (r <= 2.0)).all(), table[["profile", "controller", "kp", "shift", "ratio"]]


def test_committed_results_match(table):
    committed = pd.read_csv(REPO / "results" / "table1.csv")
    assert list(committed.columns) == tables.TABLE1_COLUMNS
    assert len(committed) == len(table)
    np.testing.assert_allclose(committed["iae_deg_s"].to_numpy(), table["iae_deg_s"].to_numpy(),
                               rtol=1e-6)
    assert (committed["shift"].to_numpy() == table["shift"].to_numpy()).all()
