"""The run folder (src/xicm/core/results/run_dir.py): layout, finding runs, episode rows, and the one list of
config keys outside a run's identity, which the fingerprint and the multirun folder names share."""

import json

import pytest
from hydra import compose, initialize_config_module
from omegaconf import OmegaConf

import xicm.conf  # noqa: F401  (registers the configs' resolvers)
from xicm.core.contracts.errors import ConfigError
from xicm.core.results.run_dir import (
    ADDED_ON_RESUME,
    GROWS_ON_RESUME,
    HOW_ON_RESUME,
    IDENTITY,
    OUTSIDE_IDENTITY,
    RunDir,
    config_fingerprint,
    find_runs,
    identity,
    outside_identity,
    override_key,
)


def make_run(folder, tasks=("a",), config=None, rows=()):
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "run.json").write_text(json.dumps({"tasks": list(tasks), "splits": {}, "config": config or {}}))
    (folder / "episodes.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    return folder


def row(task, seed, episode, success=True):
    return {"task": task, "seed": seed, "episode": episode, "success": success}


def test_layout_of_per_episode_files(tmp_path):
    run = RunDir(tmp_path)
    assert run.transcript("open_drawer", 1, 7) == tmp_path / "transcripts" / "open_drawer" / "s1-e0007.json"
    assert run.video("open_drawer", 0, 12, True) == tmp_path / "videos" / "open_drawer" / "s0-e0012-PASS.mp4"
    assert run.video("open_drawer", 0, 12, False).name == "s0-e0012-FAIL.mp4"
    assert run.video_recording("open_drawer", 0, 12).name == "s0-e0012.recording.mp4"
    assert run.relative(run.video("t", 0, 1, True)) == "videos/t/s0-e0001-PASS.mp4"
    assert (run.meta.name, run.episodes.name, run.summary.name, run.table.name, run.tasks_csv.name) == (
        "run.json", "episodes.jsonl", "summary.json", "table.md", "tasks.csv")


def test_discovery_finds_runs_and_only_runs(tmp_path):
    top = make_run(tmp_path)  # the folder given can itself be a run
    nested = make_run(tmp_path / "multirun" / "policy.k=1")
    deeper = make_run(tmp_path / "multirun" / "policy.k=2" / "again")
    (tmp_path / "only_rows").mkdir()
    (tmp_path / "only_rows" / "episodes.jsonl").write_text("")  # e.g. a merge target never finished
    (tmp_path / "only_meta").mkdir()
    (tmp_path / "only_meta" / "run.json").write_text("{}")
    (tmp_path / "folder_named" / "episodes.jsonl").mkdir(parents=True)  # a folder, not the file
    (tmp_path / "folder_named" / "run.json").write_text("{}")
    assert find_runs(tmp_path) == [top, nested, deeper]
    assert find_runs(tmp_path / "multirun") == [nested, deeper]
    assert find_runs(tmp_path / "only_rows") == [] and find_runs(tmp_path / "missing") == []


def test_rows_are_the_configured_keys_and_a_torn_line_is_dropped(tmp_path):
    run = RunDir(make_run(tmp_path, tasks=["a"], config={"seeds": [0], "episodes": 2},
                          rows=[row("a", 0, 0), row("a", 0, 1), row("a", 0, 2), row("a", 1, 0)]))
    with open(run.episodes, "a") as f:
        f.write('{"task": "a", "seed": 0, "epis')  # killed mid-write
    assert len(run.read_episodes()) == 4
    assert [(r["seed"], r["episode"]) for r in run.rows()] == [(0, 0), (0, 1)]


def test_appending_cuts_a_torn_tail_and_syncs_whole_lines(tmp_path):
    run = RunDir(tmp_path / "new")
    with run.appending_episodes() as append:  # creates the folder and the file
        append(row("a", 0, 0))
    run.episodes.write_text(run.episodes.read_text() + '{"task": "a", "se')
    with run.appending_episodes() as append:
        append(row("a", 0, 1, success=False) | {"note": "fermé"})
    lines = run.episodes.read_text(encoding="utf-8").splitlines()
    assert [json.loads(line)["episode"] for line in lines] == [0, 1]
    assert lines[1].endswith('"note": "fermé"}')  # non-ASCII kept as is


def test_a_folder_of_another_config_is_refused_with_one_sentence(tmp_path):
    run = RunDir(tmp_path)
    assert run.check_same_run({"prompt": {"k": 2}}) == {}  # no run.json yet: nothing to compare
    first = {"prompt": {"k": 2}, "seeds": [0]}
    run.meta.write_text(json.dumps({"fingerprint": config_fingerprint(first), IDENTITY: identity(first)}))
    assert run.check_same_run({"prompt": {"k": 2}, "seeds": [0, 1], "episodes": 9, "progress": False}) == {}
    with pytest.raises(ConfigError, match=r"holds episodes of a different config \(fingerprint \w+ != \w+: prompt.k 2 -> 3\); choose"):
        run.check_same_run({"prompt": {"k": 3}, "seeds": [0]})
    with pytest.raises(ConfigError, match=r"prompt.k 2 -> \(absent\)"):  # a key the run had is gone
        run.check_same_run({"prompt": {"n": 2}, "seeds": [0]})


def test_a_resume_accepts_options_declared_after_the_run_started_and_says_which(tmp_path):
    run = RunDir(tmp_path)
    first = {"prompt": {"k": 2, "path": "${paths.cache}/x"}, "seeds": [0]}
    run.meta.write_text(json.dumps({"fingerprint": config_fingerprint(first), IDENTITY: identity(first)}))
    later = {"prompt": {"k": 2, "path": "${paths.cache}/x", "score": "cosine"}, "simulator": {"robot": "ours"}, "seeds": [0]}
    assert run.check_same_run(later) == {"prompt.score": "cosine", "simulator.robot": "ours"}
    with pytest.raises(ConfigError, match=r"prompt.k 2 -> 4"):  # an added key does not hide a changed one
        run.check_same_run({**later, "prompt": {**later["prompt"], "k": 4}})
    # run.json files from before IDENTITY keep only the resolved config: compared with the resolved new one
    run.meta.write_text(json.dumps({"fingerprint": "old", "config": {"prompt": {"k": 2}, "seeds": [0], "paths": {"x": 1}}}))
    assert run.check_same_run(OmegaConf.create({"prompt": {"k": 2, "n": "${seeds}"}, "seeds": [0]})) == {"prompt.n": "[0]"}
    run.meta.write_text(json.dumps({"fingerprint": "old", ADDED_ON_RESUME: {"a.b": 1}}))
    assert run.added_on_resume({"c": 2}) == {"a.b": 1, "c": 2}


def test_options_that_say_how_a_run_is_done_neither_block_a_resume_nor_hide_a_change(tmp_path):
    run = RunDir(tmp_path)
    how = ["llm.threads", "llm.timeout_s"]
    first = {"llm": {"model": "m", "threads": 2, "timeout_s": 900}, "seeds": [0]}
    # written before the keys were marked: the identity holds them, and they are still not compared
    run.meta.write_text(json.dumps({"fingerprint": config_fingerprint(first), IDENTITY: identity(first), "config": first}))
    faster = {"llm": {"model": "m", "threads": 16, "timeout_s": 60}, "seeds": [0]}
    with pytest.raises(ConfigError, match=r"llm.threads 2 -> 16"):  # unmarked, they are what the run is
        run.check_same_run(faster)
    assert run.check_same_run(faster, how) == {}
    assert config_fingerprint(faster, how) == config_fingerprint(first, how) != config_fingerprint(first)
    assert "llm.threads" not in identity(faster, how=how) and identity(faster, how=how)["llm.model"] == "m"
    with pytest.raises(ConfigError, match=r"llm.model 'm' -> 'n'"):  # the other keys still are
        run.check_same_run({"llm": {"model": "n", "threads": 16, "timeout_s": 60}, "seeds": [0]}, how)
    # the change is told and kept: which keys, from what to what, after how many episodes
    with run.appending_episodes() as append:
        append(row("a", 0, 0))
    changed = run.how_changed(faster, how)
    assert changed == {"llm.threads": [2, 16], "llm.timeout_s": [900, 60]}
    assert run.how_on_resume(changed) == [{"episodes_before": 1, "changed": changed}]
    assert run.how_changed(first, how) == {} and run.how_on_resume({}) == []
    run.meta.write_text(json.dumps({"config": faster, HOW_ON_RESUME: [{"episodes_before": 1, "changed": changed}]}))
    assert run.how_on_resume({"llm.threads": [16, 4]})[-1] == {"episodes_before": 1, "changed": {"llm.threads": [16, 4]}}
    assert len(run.how_on_resume({"llm.threads": [16, 4]})) == 2


def test_a_resume_with_other_retrieval_features_is_refused(tmp_path):
    run = RunDir(tmp_path)
    run.check_same_metadata({"retrieval_features": "dynamics:aaaa"})  # no run.json yet: nothing to compare
    run.meta.write_text(json.dumps({"pool_size": 3600, "retrieval_features": "dynamics:aaaa"}))
    run.check_same_metadata({"pool_size": 3600, "retrieval_features": "dynamics:aaaa", "envs": 4})
    with pytest.raises(ConfigError, match=r"run with retrieval_features 'dynamics:aaaa', this run has 'dynamics:bbbb'"):
        run.check_same_metadata({"pool_size": 3600, "retrieval_features": "dynamics:bbbb"})
    with pytest.raises(ConfigError, match=r"pool_size 3600, this run has 200"):
        run.check_same_metadata({"pool_size": 200})
    run.meta.write_text(json.dumps({"pool_size": 3600}))  # recorded before the key existed: not compared
    run.check_same_metadata({"pool_size": 3600, "retrieval_features": "dynamics:bbbb"})


def test_a_run_json_without_a_config_is_refused_when_the_fingerprint_differs(tmp_path):
    run = RunDir(tmp_path)
    run.meta.write_text(json.dumps({"fingerprint": "0123"}))
    with pytest.raises(ConfigError, match=r"holds episodes of a different config \(fingerprint 0123 != \w+\); choose"):
        run.check_same_run({"prompt": {"k": 3}})


def test_override_keys_and_prefix_matching():
    assert override_key("+tracking.entity=me") == "tracking.entity"
    assert override_key("~video") == "video"
    assert override_key("+encoder@retriever.encoder=minilm") == "encoder"
    assert outside_identity("paths.data") and outside_identity("progress=false")
    assert not outside_identity("pathsX") and not outside_identity("pool_path=/p.h5")
    assert outside_identity("seeds", GROWS_ON_RESUME) and not outside_identity("seeds")


# One override for every top-level key of src/xicm/conf/config.yaml; the test fails when a key is added
# without deciding whether it belongs to a run's identity.
SAMPLE_OVERRIDES = {
    "simulator": "simulator.image_size=96", "detector": "detector=noisy_oracle", "encoder": "encoder=dynamics",
    "retriever": "retriever=random", "prompt": "prompt.name=mine", "llm": "llm=openai", "policy": "policy.k=3",
    "benchmark": "benchmark.tasks=[push_buttons]", "seeds": "seeds=[1]", "episodes": "episodes=2",
    "max_steps": "max_steps=5", "max_control_steps": "max_control_steps=40", "pool_path": "pool_path=/pools/other.h5",
    "paths": "paths.data=/elsewhere", "collect": "collect.workers=1", "export": "export.workers=1", "llm_cache": "llm_cache.enabled=false",
    "tracking": "tracking.mode=disabled", "video": "video.fps=10", "transcripts": "transcripts=false", "report": "report.html=false",
    "serve": "serve.port=9000", "envs": "envs=2",
    "shards": "shards.workers=3", "progress": "progress=false", "run_name": "run_name=mine",
}


def _compose(overrides, with_hydra=False):
    with initialize_config_module(config_module="xicm.conf", version_base="1.3"):
        return compose("config", overrides=overrides, return_hydra_config=with_hydra)


def test_every_config_key_is_sampled():
    assert set(SAMPLE_OVERRIDES) == set(_compose([]))
    assert set(OUTSIDE_IDENTITY) <= set(SAMPLE_OVERRIDES)


@pytest.mark.parametrize("key", sorted(SAMPLE_OVERRIDES))
def test_fingerprint_and_folder_name_agree_on_what_a_run_is(key):
    """A key outside a run's identity changes neither the fingerprint nor the multirun folder
    name (src/xicm/conf/config.yaml's exclude_keys); any other key changes the folder name, and the
    fingerprint too unless a resumed run may grow it (seeds, episodes)."""
    override = SAMPLE_OVERRIDES[key]
    same_fingerprint = config_fingerprint(_compose([override])) == config_fingerprint(_compose([]))
    job = _compose([override], with_hydra=True).hydra.job
    if key in OUTSIDE_IDENTITY:
        assert same_fingerprint and job.override_dirname == ""
        assert list(job.config.override_dirname.exclude_keys) == [override_key(override)]
    else:
        assert same_fingerprint == (key in GROWS_ON_RESUME)
        assert job.override_dirname == override and list(job.config.override_dirname.exclude_keys) == []
