"""Policies over the network in openpi's policy-server dialect (xicm-serve-policy, the remote policy's client).

Websocket frames of msgpack with numpy arrays, a metadata message at connect, one
`infer(obs) -> {"actions": chunk}` per message."""
