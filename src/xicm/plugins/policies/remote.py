"""Policy `remote`: ask a policy server in openpi's websocket dialect for the actions.

Each call of `act` sends the mapped observation (camera pictures under the server's image keys,
the state vector, the instruction as the prompt, and "xicm/episode" with task, seed, episode and
the call's index, which openpi servers ignore) and executes the first `chunk_steps_to_execute`
rows of the returned chunk. A server that serves an xicm policy (xicm-serve-policy) says at
connect what it needs and sends: its control mode, whether it wants the whole Observation, and
whether it observes at all (a served oracle does not: nothing is rendered between calls).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Dict, List, Optional

from xicm.core.contracts.errors import ConfigError, EpisodeFailure
from xicm.core.contracts.hookspecs import hookimpl
from xicm.core.contracts.interfaces import Policy
from xicm.core.contracts.schema import above, at_least, how
from xicm.core.contracts.spaces import GRIPPER_CLOSED, GRIPPER_OPEN, ControlSpec

DEFAULT_IMAGES = MappingProxyType({"front": "observation/image"})  # camera -> request key (read-only)
DEFAULT_STATE = ("joint_positions", "gripper_width")  # proprio fields, in order


class RemotePolicy(Policy):
    """`spec`: the simulator's ControlSpec, the one source of the control modes (names, widths)
    and proprio fields the server's chunks and the state vector are read in."""

    def __init__(self, client, options: dict, spec: ControlSpec):
        self.client = client
        self.o = options
        self.spec = spec
        meta = client.metadata.get("xicm", {}) if isinstance(client.metadata.get("xicm"), dict) else {}
        modes = spec.mode_names()
        space = options["control_mode"]
        if space == "auto":
            space = meta.get("control_mode")
            if space not in modes:
                raise ConfigError(
                    f"the server at {client.uri} does not say its control mode; set policy.control_mode to one of {', '.join(modes)}"
                )
        elif space not in modes:
            raise ConfigError(f"policy.control_mode is '{space}'; the simulator's control modes are {', '.join(modes)}")
        unknown = [f for f in options["state"] if f not in [p.name for p in spec.state]]
        if options["state_key"] and unknown:
            raise ConfigError(f"policy.state names {', '.join(unknown)}; the simulator's proprio fields are {', '.join(p.name for p in spec.state)}")
        self.control_mode = space
        self.per_step = spec.mode(space).per_step
        self.full_observation = meta.get("observation") == "full"
        self.observes = bool(meta.get("observes", True))
        self.episode: dict = {}
        self.calls = 0
        self.last_record: dict = {}

    def on_episode(self, task: str, seed: int, episode: int) -> None:
        self.episode = {"task": task, "seed": int(seed), "episode": int(episode)}

    def reset(self, task, obs, rng) -> None:
        self.calls = 0
        self.last_record = {}

    def act(self, obs):
        from xicm.serving.actions import to_actions
        from xicm.serving.client import ServerError
        from xicm.serving.observation import observation_to_wire, request_keys

        o = self.o
        try:
            request = request_keys(obs, dict(o["images"] or DEFAULT_IMAGES), o["image_size"], o["state_key"], list(o["state"]), o["prompt_key"])
        except ValueError as exc:
            raise EpisodeFailure("bad_observation", str(exc)) from exc
        request["xicm/episode"] = {**self.episode, "call": self.calls}
        if self.full_observation:
            request["xicm/observation"] = observation_to_wire(obs)
        self.calls += 1
        try:
            reply = self.client.infer(request)
        except ServerError as exc:
            raise EpisodeFailure(exc.kind, str(exc)) from exc
        if not isinstance(reply, dict) or "actions" not in reply:
            raise EpisodeFailure("bad_reply", f"the server's reply has no 'actions' (keys: {', '.join(map(str, reply)) if isinstance(reply, dict) else type(reply).__name__})")
        if isinstance(reply.get("xicm/record"), dict):
            self.last_record = reply["xicm/record"]
        failure = reply.get("xicm/failure")
        if isinstance(failure, dict):  # the served policy gave up (xicm-serve-policy)
            raise EpisodeFailure(str(failure.get("kind", "server_error")), str(failure.get("message", "")))
        space = reply.get("xicm/control_mode", self.control_mode)
        if space not in self.spec.mode_names():
            raise EpisodeFailure("bad_reply", f"the server's control mode {space!r} is not one of {', '.join(self.spec.mode_names())}")
        try:
            actions = to_actions(reply["actions"], self.spec.mode(space), o["gripper_open"], o["gripper_closed"])
        except ValueError as exc:
            raise EpisodeFailure("bad_reply", str(exc)) from exc
        keep = o["chunk_steps_to_execute"]
        return actions if keep is None else actions[: int(keep)]

    def act_batch(self, peers, observations) -> list:
        """All environments' requests at once, each over its own connection (a batching server
        sees them together)."""
        from concurrent.futures import ThreadPoolExecutor

        def one(pair):
            peer, obs = pair
            try:
                return peer.act(obs)
            except Exception as exc:  # noqa: BLE001 - that environment's episode records it
                return exc

        with ThreadPoolExecutor(max_workers=len(peers)) as pool:
            return list(pool.map(one, zip(peers, observations)))

    def run_metadata(self) -> dict:
        return {"server": self.client.uri, "server_metadata": _jsonable(self.client.metadata), "control_mode": self.control_mode}

    def record(self) -> dict:
        return dict(self.last_record)


def _jsonable(value):
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    return value if isinstance(value, (str, int, float, bool)) or value is None else repr(value)


@dataclass
class RemotePolicyOptions:
    host: str = "127.0.0.1"  # or a ws:// / wss:// URI
    port: Optional[int] = field(default=8000, metadata=at_least(1))
    timeout_s: float = field(default=30.0, metadata=how(above(0)))  # per request, and for connecting
    api_key_env: Optional[str] = field(default=None, metadata=how())  # the NAME of the environment variable holding the server's key
    control_mode: str = "auto"  # auto, or one of the simulator's control modes (checked when built)
    chunk_steps_to_execute: Optional[int] = field(default=None, metadata=at_least(1))  # null: the whole chunk
    # camera -> request key; null: {front: observation/image}. Null in the YAML so that a mapping
    # given on the command line replaces it whole (Hydra merges into an existing mapping)
    images: Optional[Dict[str, str]] = None
    image_size: Optional[int] = field(default=None, metadata=at_least(1))  # null: as rendered
    state_key: Optional[str] = "observation/state"
    state: List[str] = field(default_factory=lambda: list(DEFAULT_STATE))  # proprio fields, in order
    prompt_key: Optional[str] = "prompt"
    gripper_open: float = GRIPPER_OPEN  # the server's value for an open gripper
    gripper_closed: float = GRIPPER_CLOSED  # ... and for a closed one


def create_remote_policy(options: RemotePolicyOptions, context) -> RemotePolicy:
    from xicm.serving.client import PolicyClient, ServerError, server_uri
    from xicm.serving.keys import KeyNotSet, key_from_env

    settings = {**dataclasses.asdict(options), "images": dict(options.images or DEFAULT_IMAGES)}  # what RemotePolicy reads
    api_key_env = options.api_key_env
    try:
        api_key = key_from_env(api_key_env, "policy.api_key_env")  # held by the client only, never in options
    except KeyNotSet as exc:
        raise ConfigError(str(exc)) from None
    client = PolicyClient(server_uri(options.host, options.port), options.timeout_s, api_key)
    try:
        client.connect()
    except ServerError as exc:
        raise ConfigError(_refusal(exc, api_key_env) if exc.status in (401, 403) else f"policy.host/port: {exc}") from exc
    spec = context.simulator.control_spec()
    try:
        policy = RemotePolicy(client, settings, spec)
    except ConfigError:
        client.close()
        raise
    if policy.per_step and policy.control_mode != spec.control_mode:
        client.close()
        raise ConfigError(
            f"policy.control_mode is {policy.control_mode} but simulator.control_mode is {spec.control_mode}; per-step actions are stepped in the simulator's control mode"
        )
    return policy


def _refusal(exc, api_key_env: str | None) -> str:
    """The one sentence for a server that refused our key (or wanted one)."""
    if not api_key_env:
        return f"{exc}: it needs a key; export it in an environment variable and set policy.api_key_env to that variable's name"
    return f"{exc}: check the key in ${api_key_env} (policy.api_key_env)"


def check_remote_config(cfg, registry) -> None:
    if "@" in str(cfg.policy.host).split("//", 1)[-1].split("/", 1)[0]:
        raise ConfigError("policy.host must not hold credentials (user:password@): put the key in an environment variable named by policy.api_key_env")
    if float(cfg.policy.gripper_open) == float(cfg.policy.gripper_closed):
        raise ConfigError("policy.gripper_open and policy.gripper_closed must differ")


@hookimpl
def register_policies(register):
    register("remote", create_remote_policy, options=RemotePolicyOptions, check=check_remote_config)
