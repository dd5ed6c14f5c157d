"""Policies over the network in openpi's policy-server dialect: websocket frames of msgpack with
numpy arrays, a metadata message at connect, one `infer(obs) -> {"actions": chunk}` per message."""
