"""Exceptions with a one-sentence message meant for the user.

Errors during an episode become `EpisodeResult.error_kind` (the kind strings below) and the
run goes on; ConfigError stops a run before its first episode.
"""


import sys


class XicmError(Exception):
    """Base class of xicm's own errors."""


def exit_with_error(exc: Exception) -> None:
    """A console script's end on a user error: its one sentence on stderr, exit status 2."""
    print(f"xicm: error: {exc}", file=sys.stderr)
    sys.exit(2)


class ConfigError(XicmError):
    """A config names something that does not exist (plugin, model file, dataset)."""


class LLMError(XicmError):
    """The LLM could not answer (server unreachable, timeout after retries, bad reply shape)."""

    kind = "llm_error"


class EpisodeFailure(XicmError):
    """Ends an episode as a failure of a given kind; the run goes on."""

    def __init__(self, kind: str, message: str):
        super().__init__(message)
        self.kind = kind
        self.message = message


# Error kinds recorded in episodes.jsonl.
ERROR_KINDS = (
    "parse_error",  # the reply held no usable 7-integer action
    "llm_error",  # the LLM failed to answer
    "unreachable",  # IK/planning could not reach a pose
    "out_of_workspace",  # simulator.workspace_check: rlbench: a target RLBench's workspace check refuses (InvalidActionError)
    "sim_error",  # the simulator raised during the episode
    "unsolvable_scene",  # simulator.scenes: rlbench: no draw of the scene was solved by the task's demonstrator
    "detector_error",  # the detector failed
    "retrieval_error",  # the retriever failed
    "max_steps",  # the step budget ran out without success
    "max_control_steps",  # the control-step budget of a per-step policy ran out without success
    "bad_action",  # a per-step action of the wrong shape or with NaN / infinite values
    "max_llm_calls",  # the LLM-call budget ran out without success
    "no_actions",  # the policy returned no action
    "solution_ended",  # the scripted solution (oracle policy) ran out without success
    "server_unreachable",  # policy=remote: no policy server answered, or the link was lost
    "server_refused",  # policy=remote: the server refused the connection (no key or a wrong key, all its sessions in use)
    "server_timeout",  # policy=remote: the server did not answer within policy.timeout_s
    "server_error",  # policy=remote: the server failed to answer the request
    "bad_reply",  # policy=remote: the reply could not be decoded (src/xicm/serving/wire.py), had no actions, a wrong shape, or NaN/inf
    "bad_observation",  # policy=remote: the observation lacks what the mapping sends (a camera, a state field)
    "internal_error",  # an unexpected exception in our own code (a bug: please report it)
)
