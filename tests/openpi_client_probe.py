"""Run inside the openpi-client environment (not xicm's): connect to a policy server with
openpi's own WebsocketClientPolicy, send one observation, and save what came back.

    python openpi_client_probe.py HOST PORT OUT.npz [API_KEY_ENV]

With API_KEY_ENV, the key in that environment variable goes to WebsocketClientPolicy(api_key=...).
"""

import os
import sys

import numpy as np
from openpi_client import msgpack_numpy
from openpi_client.websocket_client_policy import WebsocketClientPolicy

host, port, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
api_key = os.environ[sys.argv[4]] if len(sys.argv) > 4 else None
client = WebsocketClientPolicy(host=host, port=port, api_key=api_key)
obs = {
    "observation/image": np.arange(4 * 4 * 3, dtype=np.uint8).reshape(4, 4, 3),
    "observation/state": np.linspace(0, 1, 8, dtype=np.float32),
    "prompt": "close the box",
}
reply = client.infer(obs)
frame = msgpack_numpy.packb({"actions": np.eye(3, 8, dtype=np.float64), "step": np.int32(5)})
np.savez(
    out,
    actions=reply["actions"],
    metadata_action_dim=np.asarray(client.get_server_metadata()["action_dim"]),
    openpi_frame=np.frombuffer(frame, dtype=np.uint8),
)
