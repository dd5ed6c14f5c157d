"""xicm-serve-policy: build the configured run (simulator + policy) and serve the policy."""

from __future__ import annotations

import logging

from omegaconf import DictConfig, OmegaConf

from xicm.core.assembly.build import Run, build_run
from xicm.core.assembly.checks import check_run
from xicm.core.contracts.errors import ConfigError
from xicm.core.assembly.plugins import get_registry
from xicm.core.execution.sim_process import simulator_processes
from xicm.serving.keys import KeyNotSet, key_from_env
from xicm.serving.served_policy import ServedPolicies
from xicm.serving.server import PolicyServer


def serve_policy(cfg: DictConfig, ready=None) -> None:
    """Serve until interrupted; `ready(server)` is called once the port is open (tests, scripts)."""
    registry = get_registry()
    check_run(cfg, registry, list(cfg.benchmark.tasks))
    config = OmegaConf.to_container(cfg, resolve=True)

    warm_up = (str(cfg.benchmark.tasks[0]), 0, 0)

    def build() -> Run:  # a session: its simulator in a worker process (warmed up, not on a client's clock), its policy here
        return build_run(cfg, registry, simulator=simulator_processes(config, 1, warm_up)[0])

    try:
        api_key = key_from_env(cfg.serve.api_key_env, "serve.api_key_env")
    except KeyNotSet as exc:
        raise ConfigError(str(exc)) from None
    if int(cfg.serve.sessions) > int(cfg.serve.max_sessions):
        raise ConfigError(f"serve.sessions ({cfg.serve.sessions}) is over serve.max_sessions ({cfg.serve.max_sessions}): sessions past the cap would never be used")
    served = ServedPolicies(build, sessions=int(cfg.serve.sessions), instructions=str(cfg.benchmark.instructions),
                             scene_seed=cfg.benchmark.scene_seed)
    idle = cfg.serve.idle_timeout_s
    server = PolicyServer(served, host=str(cfg.serve.host), port=int(cfg.serve.port), metadata=served.metadata(),
                          api_key=api_key, max_sessions=int(cfg.serve.max_sessions),
                          idle_timeout_s=None if idle is None else float(idle), key_setting="serve.api_key_env")
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    try:
        server.start()
        print(f"serving policy '{cfg.policy.name}' on ws://{server.host}:{server.port} (health: http://{server.host}:{server.port}/healthz)", flush=True)
        if ready is not None:
            ready(server)
        server.wait()
    except KeyboardInterrupt:
        pass
    finally:
        server.stop()
        served.close()
