"""A bad parameter raises crandall.ParameterError naming it, across the layers: the analytic
forms, scenes and envelopes, histograms' estimates, results, figures, fragility, the command
line and the files (docs/architecture.md)."""

import importlib
import pickle

import numpy as np
import pytest

import crandall
from crandall import analytic, checkpoint, cli, distributions, envelopes
from crandall._dataset import sweep
from crandall._files import check_file_writable
from crandall.errors import ParameterError, UnresolvableGrid
from crandall.units import Scaling

F = importlib.import_module("crandall.fragility")  # the package (crandall.fragility is the function)


def _names(call):
    with pytest.raises(ParameterError) as info:
        call()
    assert isinstance(info.value, ValueError)  # callers that catch ValueError are unchanged
    assert str(info.value).startswith(info.value.name.split(", ")[0]), info.value
    return info.value.name


@pytest.mark.parametrize("call, name", [
    (lambda: analytic.velocity_var(float("nan")), "tau"),
    (lambda: analytic.distance_mean(1.0, tau0=-1.0), "tau0"),
    (lambda: crandall.Scene.from_dict({"units": "imperial"}), "units"),
    (lambda: crandall.Scene.from_dict({"units": "SI", "colour": 1}), "colour"),
    (lambda: envelopes.amin_ang(0.6, t1=2.0, t2=1.0, c=0.4), "t2"),
    (lambda: envelopes.Envelope.from_dict({"kind": "nonesuch"}), "envelope.kind"),
    (lambda: distributions.quantile([0.0, 1.0, 2.0], [1, 1], 0, 0, q=1.5), "q"),
    (lambda: distributions.quantile([0.0, 1.0, 1.0], [1, 1], 0, 0, q=0.5), "edges"),
    (lambda: Scaling(mu=0.1, h=0.1, g=9.81).scale("colour"), "kind"),
    (lambda: sweep([]), "results"),
    (lambda: cli.run(max_seconds=5, files=False), "--max-seconds"),
])
def test_a_bad_value_names_its_parameter(call, name):
    assert _names(call) == name


def test_files_and_checkpoints_name_their_parameter(tmp_path):
    assert _names(lambda: check_file_writable(str(tmp_path), "checkpoint")) == "checkpoint"
    ident = checkpoint.run_identity(checkpoint.PATHS, {})
    arrays = {"identity": np.zeros(1)}
    assert _names(lambda: checkpoint.write(tmp_path / "c.npz", ident, arrays)) == "arrays"
    assert not (tmp_path / "c.npz").exists()


@pytest.fixture(scope="module")
def result():
    scene = crandall.Scene.scaled(tau0=1, times=[1], distributions=["stop_time"])
    return crandall.simulate(scene, paths=1000, seed=1)


def test_results_name_their_parameter(result):
    assert _names(lambda: result.mean("nonesuch")) == "name"
    assert _names(lambda: result.quantile("stop_time", 1.5)) == "q"
    assert _names(lambda: result.moment(3, 2, 0)) == "j, k, l"
    assert _names(lambda: result.interval("distance", "median")) == "stat"


def test_figures_and_fragility_name_their_parameter(result):
    pytest.importorskip("matplotlib")
    from crandall import plots
    assert _names(lambda: plots.distance_mean(result, units="furlongs")) == "units"
    assert _names(lambda: plots.distribution(result, "distance_at_stop")) == "name"
    assert _names(lambda: plots.fragility(result)) == "result"
    assert _names(lambda: F.FragilityResult(
        quantity="stop_time", axis="colour", values=np.array([1.0]),
        thresholds=np.array([1.0]), run=np.zeros(1, int), probability=np.zeros((1, 1)),
        stderr=np.zeros((1, 1)), low=np.zeros((1, 1)), high=np.zeros((1, 1)),
        reliable=np.ones((1, 1), bool))) == "axis"


def test_parameter_errors_survive_pickling():
    # A Dask worker's error comes back to the client pickled.
    e = pickle.loads(pickle.dumps(ParameterError("mu", "mu must be >= 0, got -1")))
    assert (type(e), e.name, str(e)) == (ParameterError, "mu", "mu must be >= 0, got -1")
    g = pickle.loads(pickle.dumps(UnresolvableGrid(["distance"], "observe: too fine")))
    assert (type(g), g.name, g.integrals, str(g)) == (UnresolvableGrid, "observe", ("distance",),
                                                      "observe: too fine")


def test_the_entry_points_name_their_parameter():
    scene = crandall.Scene.scaled(tau0=1.0, times=[1.0])
    assert _names(lambda: crandall.simulate(scene, seed=1)) == "paths"
    assert _names(lambda: crandall.simulate(scene, paths=10, statistics=["x"])) == "statistics"
    assert _names(lambda: crandall.simulate(scene, paths=10, max_seconds=1.0)) == "max_seconds"
    assert _names(lambda: crandall.simulate(scene, paths=10, method="midpoint")) == "method"
    assert _names(lambda: crandall.simulate_many([], paths=10)) == "scenes"
    assert _names(lambda: crandall.simulate_many([scene, "crate"], paths=10)) == "scenes"
    assert _names(lambda: crandall.simulate_many([scene], paths=10, dataset=1)) == "dataset"
    moving = crandall.simulate(crandall.Scene(mu=0.3, h=1.0, t0=1.0, v0=0.5, times=[1.0]),
                               paths=10, seed=1)
    assert _names(lambda: crandall.paper.scaled_factors(moving)) == "result"


def test_runs_to_an_accuracy_name_their_parameter():
    scene = crandall.Scene.scaled(tau0=1.0, times=[1.0])
    assert _names(lambda: crandall.simulate(scene, error=0.1, rel_error=0.1)) == "error, rel_error"
    assert _names(lambda: crandall.simulate(scene, error=0.1, statistics=["nonesuch:mean"])) \
        == "statistics"
    assert _names(lambda: crandall.simulate(scene, error=0.1, statistics=[])) == "statistics"
    peaks = crandall.Scene.scaled(tau0=1.0, times=[1.0], observe=["velocity", "peaks"])
    assert _names(lambda: crandall.simulate(peaks, error=0.1)) == "observe"
