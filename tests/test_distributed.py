"""Dask: chunk ranges as tasks on a LocalCluster of two worker processes, bitwise the local run."""

import numpy as np
import pytest

import crandall
from crandall import _core, cli
from conftest import same_result

distributed = pytest.importorskip("distributed")

CHUNK = _core.CHUNK_PATHS


@pytest.fixture(scope="module")
def client():
    # Ephemeral ports for the scheduler and its HTTP server: the suite must pass next to another Dask
    # cluster on the machine (a scheduler's default dashboard port, 8787, may be held).
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       scheduler_port=0, dashboard_address=":0",
                                       worker_dashboard_address=None)
    c = distributed.Client(cluster)
    try:
        yield c
    finally:
        c.close()
        cluster.close()


def scene(tau0=1.0):
    return crandall.Scene.scaled(tau0=tau0, times=[0.25, 0.5, 1.0, 1.5])


def test_cluster_result_is_bitwise_the_local_one(client):
    paths = 3 * CHUNK + 17
    local = crandall.simulate(scene(), paths=paths, seed=21, dt=0.1)
    remote = crandall.simulate(scene(), paths=paths, seed=21, dt=0.1, client=client)
    assert same_result(local, remote)
    np.testing.assert_array_equal(local.moment(2, 1, 1), remote.moment(2, 1, 1))
    assert remote.seed == 21 and remote.paths == paths
    # The work really ran on both workers' processes.
    assert len(client.scheduler_info()["workers"]) == 2


def test_parameter_sweep(client):
    scenes = [scene(tau0) for tau0 in (0.5, 1.0, 2.0)]
    paths = CHUNK + 500
    remote = crandall.simulate_many(scenes, paths=paths, seed=8, dt=0.1, client=client)
    local = crandall.simulate_many(scenes, paths=paths, seed=8, dt=0.1)
    assert len(remote) == len(local) == 3
    for sc, r, l in zip(scenes, remote, local):
        assert r.scene is sc
        assert same_result(r, l)
        assert same_result(r, crandall.simulate(sc, paths=paths, seed=8, dt=0.1))


def test_cluster_run_with_checkpoint(client, tmp_path):
    paths = 3 * CHUNK
    path = tmp_path / "c.ckpt"
    remote = crandall.simulate(scene(), paths=paths, seed=2, dt=0.1, client=client,
                               checkpoint=path)
    local = crandall.simulate(scene(), paths=paths, seed=2, dt=0.1, checkpoint=path)  # complete
    assert same_result(remote, local)
    assert same_result(local, crandall.simulate(scene(), paths=paths, seed=2, dt=0.1))


def test_cli_scheduler_option(client, tmp_path, capsys):
    scene_file = tmp_path / "s.toml"
    scene_file.write_text("[scene]\nunits = 'scaled'\ntau0 = 1.0\ntimes = [0.25, 0.5, 1.0, 1.5]"
                          "\n[run]\npaths = 70000\nseed = 5\ndt = 0.1\n")
    address = client.scheduler.address
    assert cli.main(["run", str(scene_file), "--scheduler", address, "--no-files"]) == 0
    out = capsys.readouterr().out
    assert f"on {address}" in out
    local = crandall.simulate(scene(), paths=70000, seed=5, dt=0.1)
    assert local.estimate_bias().summary() in out


def test_simulate_many_bad_input():
    with pytest.raises(ValueError, match="scenes"):
        crandall.simulate_many(scene(), paths=10)
    with pytest.raises(ValueError, match="scenes"):
        crandall.simulate_many([], paths=10)
    with pytest.raises(ValueError, match=r"scenes\[1\]"):
        crandall.simulate_many([scene(), "x"], paths=10)


def test_run_to_an_accuracy_on_the_cluster_is_bitwise_local(client):
    # The batches of every round are Dask tasks, merged in batch order.
    sc = crandall.Scene.scaled(tau0=2.0, times=[1.0, 2.0], observe=["distance", "stop"])
    local = crandall.simulate(sc, error=2e-2, seed=8, threads=2)
    remote = crandall.simulate(sc, error=2e-2, seed=8, client=client)
    cols = ["mean", "var", "stderr", "var_stderr", "bias_mean", "bias_var"]
    np.testing.assert_array_equal(remote.to_pandas()[cols].to_numpy(),
                                  local.to_pandas()[cols].to_numpy())
    assert remote.cost["paths"] == local.cost["paths"]


def test_a_filtered_run_to_an_accuracy_on_the_cluster_is_bitwise_local(client):
    # Its levels (model.FILTERED_LEVELS) are rebuilt on the workers from the scene's data.
    sc = crandall.Scene(mu=0.0, g=1.0, t0=10.0, times=[0.5], observe=["velocity", "distance"],
                        excitation=crandall.KanaiTajimi(omega=2.0, zeta=0.6, h=1.0))
    args = dict(rel_error=0.02, seed=8, statistics=["velocity:var", "distance:mean"])
    local = crandall.simulate(sc, threads=2, **args)
    remote = crandall.simulate(sc, client=client, **args)
    assert remote.model == "filtered_levels"
    assert remote.to_pandas().equals(local.to_pandas())
    assert remote.cost["paths"] == local.cost["paths"]


def test_a_filtered_run_that_refits_its_controls_on_the_cluster_is_bitwise_local(client,
                                                                                 monkeypatch):
    # The refit (adaptive.levels.REFIT_PILOT) forced as in tests/test_filtered_error.py: its
    # pilot runs here, the batches after it on the workers with the new coefficients.
    from crandall import adaptive
    monkeypatch.setattr(adaptive.levels, "REFIT_PILOT", 4 * adaptive.PILOT_PATHS)
    monkeypatch.setattr(adaptive.levels, "REFIT_RATIO", 0.25)
    sc = crandall.Scene(mu=1.0, g=1.0, t0=10.0, times=[2.0], observe=["velocity", "distance"],
                        excitation=crandall.KanaiTajimi(omega=2.0, zeta=0.6, h=1.0))
    args = dict(rel_error=0.01, seed=21, statistics=["velocity:var", "distance:mean"])
    local = crandall.simulate(sc, threads=2, **args)
    remote = crandall.simulate(sc, client=client, **args)
    assert remote.to_pandas().equals(local.to_pandas())
    assert remote.cost["path_steps"] == local.cost["path_steps"]
    # It did refit: the base level drew its two pilots (4096 and 16384) and the first round's
    # estimation paths besides the estimate's.
    base = local.levels[0]
    assert local.cost["path_steps"] > (5 * adaptive.PILOT_PATHS + base["paths"]) \
        * base["steps_per_path"] + sum(lv["paths"] * lv["steps_per_path"] * 1.5
                                        for lv in local.levels[1:])


def test_cluster_histograms_and_peaks_are_bitwise_the_local_ones(client):
    s = crandall.Scene.scaled(tau0=1.0, times=[0.5, 1.5], observe=["velocity", "stop", "peaks"],
                              distributions=True)
    paths = 2 * CHUNK + 5
    local = crandall.simulate(s, paths=paths, seed=8, method="exact")
    remote = crandall.simulate(s, paths=paths, seed=8, method="exact", client=client)
    hl, hr = local.accumulators.histograms, remote.accumulators.histograms
    assert hl.index == hr.index
    for a, b in zip(hl.edges + hl.counts, hr.edges + hr.counts):
        assert a.dtype == b.dtype and a.tobytes() == b.tobytes()
    assert local.mean("peak_speed").tobytes() == remote.mean("peak_speed").tobytes()
    assert remote.quantile("stop_time", 0.99) == local.quantile("stop_time", 0.99)


def test_scenes_beyond_the_paper_on_the_cluster_are_bitwise_local(client):
    # A start in motion and a piecewise intensity travel to the workers in the scene's data.
    sc = crandall.Scene(mu=0.3, h=[1.0, 0.0, 0.5], t0=[1.0, 1.5, 2.5], v0=0.4, u0=0.1,
                        times=[0.5, 2.0, 3.0])
    local = crandall.simulate(sc, paths=70_000, seed=4, threads=2)
    remote = crandall.simulate(sc, paths=70_000, seed=4, client=client)
    for name in local.names:
        assert np.asarray(remote.var(name)).tobytes() == np.asarray(local.var(name)).tobytes()
    a_local = crandall.simulate(sc, error=5e-2, seed=4, threads=2)
    a_remote = crandall.simulate(sc, error=5e-2, seed=4, client=client)
    assert a_remote.to_pandas().equals(a_local.to_pandas())


def test_an_envelope_scene_on_the_cluster_is_bitwise_local(client):
    # The envelope travels as plain data and is rebuilt on the workers (its pieces, the
    # same bits); the piece error is estimated on the client, the same as locally.
    from crandall import envelopes
    sc = crandall.Scene(mu=0.35, envelope=envelopes.amin_ang(0.6, t1=1.0, t2=2.0, c=1.0,
                                                              end=4.0, pieces=6),
                        times=[1.0, 3.0], observe=["velocity", "distance", "stop"])
    local = crandall.simulate(sc, paths=3000, seed=4, threads=2)
    remote = crandall.simulate(sc, paths=3000, seed=4, client=client)
    # Both chose the same pieces (crandall.pieces: a pure function of the run), more than 6.
    assert remote.scene == local.scene and remote.scene.envelope == local.scene.envelope
    assert remote.scene.envelope.pieces > sc.envelope.pieces
    for name in local.names:
        for stat in ("mean", "var"):
            assert np.asarray(getattr(remote, stat)(name)).tobytes() == \
                np.asarray(getattr(local, stat)(name)).tobytes()
            assert np.asarray(remote.bias(name, stat)).tobytes() == \
                np.asarray(local.bias(name, stat)).tobytes()
