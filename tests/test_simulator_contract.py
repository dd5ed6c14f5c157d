"""check_simulator (xicm.core.contracts.simulator_check), the contract check any simulator plugin can run,
passes on SAPIEN rendered and physics-only, and names the breach when a simulator breaks it."""

import numpy as np
import pytest

from xicm.core.contracts.simulator_check import ContractBreach, check_simulator


@pytest.fixture(scope="module")
def physics():
    from xicm.core.assembly.plugins import get_registry

    simulator = get_registry().create_simulator({"name": "sapien", "render": False, "control_mode": "joint_delta"})
    yield simulator
    simulator.close()


def test_sapien_rendered_keeps_the_contract(sim):
    report = check_simulator(sim, "push_buttons", seed=0, episode=1, replay=False)
    assert report["skipped"] == []
    assert {"catalogue", "control_spec", "reset", "image_sizes", "step refuses bad actions"} <= set(report["checked"])


def test_sapien_physics_only_keeps_the_contract_and_its_recording_replays(physics):
    report = check_simulator(physics, "open_drawer", seed=10_000, episode=0, render=False)
    assert report["skipped"] == [] and "record_scripted + replay" in report["checked"]


def test_a_proprio_off_its_declared_layout_is_named(physics, monkeypatch):
    real = physics.proprio
    monkeypatch.setattr(physics, "proprio", lambda: {k: v for k, v in real().items() if k != "tcp_pose"})
    with pytest.raises(ContractBreach, match=r"proprio\(\): proprio fields .* are not control_spec\(\).state's"):
        check_simulator(physics, "open_drawer", render=False, replay=False)


def test_a_step_that_raises_on_a_bad_action_is_named(physics, monkeypatch):
    def strict(action):
        return np.asarray(action, dtype=float).reshape(8)  # raises ValueError for the wrong width

    monkeypatch.setattr(physics, "step", strict)
    with pytest.raises(ContractBreach, match=r"step\(\) raised ValueError for a bad action"):
        check_simulator(physics, "open_drawer", render=False, replay=False)


def test_a_simulator_in_a_worker_process_keeps_the_contract():
    """envs=N and xicm-serve-policy drive SimulatorProcess: every contract method crosses the pipe."""
    from hydra import compose, initialize_config_module
    from omegaconf import OmegaConf

    from xicm.core.contracts.interfaces import Simulator
    from xicm.core.execution.sim_process import SimulatorProcess

    local_only = {"set_frame_callback"}  # a callback cannot cross a process boundary
    contract = {n for n, f in vars(Simulator).items() if callable(f) and not n.startswith("_")} - local_only
    assert contract - set(vars(SimulatorProcess)) == set()
    with initialize_config_module(config_module="xicm.conf", version_base="1.3"):
        cfg = compose("config", overrides=["simulator.image_size=32", "simulator.cameras=[front]", "simulator.control_mode=ee_pose"])
    cfg.run_name = cfg.tracking.group = "test"  # their ${hydra:...} resolves only inside a Hydra app
    sim = SimulatorProcess(OmegaConf.to_container(cfg, resolve=True))
    try:
        report = check_simulator(sim, "open_drawer", seed=10_000, episode=0)
        assert report["skipped"] == [] and "record_scripted + replay" in report["checked"]
        assert sim.control_spec().control_mode == "ee_pose"
    finally:
        sim.close()
