"""xicm-serve-policy: build the configured run (simulator + policy) and serve the policy."""

from __future__ import annotations

import logging

from omegaconf import DictConfig

from xicm.core.build import build_run, check_run
from xicm.core.plugins import get_registry
from xicm.serving.served_policy import ServedPolicies
from xicm.serving.server import PolicyServer


def serve_policy(cfg: DictConfig, ready=None) -> None:
    """Serve until interrupted; `ready(server)` is called once the port is open (tests, scripts)."""
    registry = get_registry()
    check_run(cfg, registry, list(cfg.benchmark.tasks))
    served = ServedPolicies(lambda: build_run(cfg, registry), control_mode=cfg.simulator.get("control_mode"))
    server = PolicyServer(served, host=str(cfg.serve.host), port=int(cfg.serve.port), metadata=served.metadata())
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
