"""--workers N on a local cluster never starts more workers than runs to do (a note says so)."""


def test_local_workers_are_capped_at_the_runs_to_do(tmp_path, monkeypatch):
    from mjasc.campaigns import engine

    seen = {}

    def on_dask(runs, store, out_dir, scheduler, workers, *rest):
        seen["workers"] = workers

    monkeypatch.setattr(engine, "run_on_dask", on_dask)
    info = engine.execute_runs([object(), object()], None, tmp_path, workers=1000, progress=False, hulls={})
    assert seen["workers"] == 2 and info["workers_asked"] == 1000
