"""Decoding frames from an untrusted peer (src/xicm/serving/wire.py): only bool, integer and float arrays,
shapes that match their bytes, caps on sizes and nesting; anything else is one WireError, never a
crash. Then the same frames against a real policy server and client on 127.0.0.1."""

import dataclasses
import random

import msgpack
import numpy as np
import pytest
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

from xicm.core.contracts.errors import EpisodeFailure
from xicm.core.contracts.spaces import ControlSpec, key_pose_mode, layout
from xicm.core.contracts.types import CameraFrame, KeyAction, Observation
from xicm.plugins.policies.remote import RemotePolicy, RemotePolicyOptions
from xicm.serving import wire
from xicm.serving.client import PolicyClient, ServerError, server_uri
from xicm.serving.server import PolicyServer
from xicm.serving.wire import WireError, pack, unpack

ACCEPTED_KINDS = "biuf"
LETTERS = sorted(set(np.typecodes["All"]) | set("OVSUMmc"))


def array_map(dtype, shape, data):
    return {b"__ndarray__": True, b"data": data, b"dtype": dtype, b"shape": shape}


def frame(obj):
    return msgpack.packb(obj, use_bin_type=True)


# --- dtypes -----------------------------------------------------------------------------------


@pytest.mark.parametrize("letter", LETTERS)
def test_every_numpy_dtype_letter_is_accepted_only_when_bool_integer_or_float(letter):
    dtype = np.dtype(letter)
    data = b"\x01" * (3 * dtype.itemsize)
    for spec in (dtype.str, letter):  # as numpy writes it ("|O", "<f8") and as the bare letter
        crafted = frame({"x": array_map(spec, [3], data)})
        if dtype.kind in ACCEPTED_KINDS:
            back = unpack(crafted)["x"]
            assert back.dtype == dtype and back.shape == (3,) and back.tobytes() == data
        else:
            with pytest.raises(WireError, match="only bool, integer and float dtypes"):
                unpack(crafted)
        scalar = frame({"s": {b"__npgeneric__": True, b"data": 1, b"dtype": spec}})
        if dtype.kind in ACCEPTED_KINDS:
            assert unpack(scalar)["s"] == 1 and unpack(scalar)["s"].dtype == dtype
        else:
            with pytest.raises(WireError):
                unpack(scalar)


@pytest.mark.parametrize("letter", [c for c in LETTERS if np.dtype(c).kind in ACCEPTED_KINDS])
def test_numeric_and_bool_arrays_round_trip_through_pack(letter):
    value = (np.arange(24) % 2 if letter == "?" else np.arange(24)).astype(letter).reshape(2, 3, 4)
    for array in (value, value.astype(value.dtype.newbyteorder()), value[:, ::2]):  # other byte order, a strided view
        scalar = array.flat[5] if letter != "g" else 5  # pack cannot send a longdouble scalar (its item() is itself)
        back = unpack(pack({"a": array, "s": scalar}))
        assert back["a"].dtype == array.dtype and back["a"].shape == array.shape
        np.testing.assert_array_equal(back["a"], array)
        # scalars come back native-endian; float64 is a Python float subclass and travels as a float
        assert back["s"] == scalar and (letter == "g" or np.asarray(back["s"]).dtype == array.dtype.newbyteorder("="))
        assert not back["a"].flags.writeable


def test_pack_still_refuses_object_void_and_complex():
    for value in (np.array([object()]), np.zeros(2, dtype="V4"), np.zeros(2, dtype=np.complex64), np.complex128(1j)):
        with pytest.raises(TypeError, match="refused"):
            pack({"x": value})


@pytest.mark.parametrize(
    "spec", ["", "no such dtype", "f4,i4", "(2,)f4", "[('a', '<f4')]", "<f4" * 10, "O8", "S3", "<U2", "M8[s]", "<c16"]
)
def test_dtypes_numpy_cannot_read_or_that_are_not_plain_numbers_are_refused(spec):
    with pytest.raises(WireError, match="dtype"):
        unpack(frame(array_map(spec, [1], b"\x00" * 8)))


@pytest.mark.parametrize("spec", [3, None, b"<f4", ["<f4"], True])
def test_a_dtype_that_is_not_a_string_is_refused(spec):
    with pytest.raises(WireError, match="dtype that is not a short string"):
        unpack(frame(array_map(spec, [1], b"\x00" * 4)))


def test_the_object_array_that_crashed_the_evaluator_is_refused():
    pointers = np.array([0xDEADBEEF, 8], dtype="<u8").tobytes()
    with pytest.raises(WireError, match=r"dtype '\|O'"):
        unpack(frame({"actions": array_map("|O", [2], pointers)}))


# --- shapes and bytes -------------------------------------------------------------------------


@pytest.mark.parametrize(
    "shape, data, words",
    [
        ([2, 3], b"\x00" * 23, "needs 24 bytes but its data has 23"),
        ([2, 3], b"\x00" * 25, "needs 24 bytes but its data has 25"),
        ([], b"", "needs 4 bytes but its data has 0"),
        ([0, 7], b"\x00" * 4, "needs 0 bytes but its data has 4"),
        ([-1], b"\x00" * 4, "non-negative integers"),
        ([2, -3], b"\x00" * 24, "non-negative integers"),
        ([2**40, 2**40], b"\x00" * 4, "over the cap"),
        ([2**64 - 1, 2**64 - 1, 2**64 - 1], b"", "over the cap"),  # the product overflows any fixed-width int
        ([2**32, 2**32, 0], b"", "over the cap"),  # zero elements, but numpy cannot make it
        ([0, 2**20], b"", None),  # zero elements: a valid empty array
        ([1.5], b"\x00" * 4, "non-negative integers"),
        ([True], b"\x00" * 4, "non-negative integers"),
        (["2"], b"\x00" * 8, "non-negative integers"),
        (2, b"\x00" * 8, "not a list"),
        (None, b"\x00" * 8, "not a list"),
        ([1] * 33, b"\x00" * 4, "at most 32"),
        ([1], "text", "data is not bytes"),
        ([1], None, "data is not bytes"),
        ([1], [0, 0, 0, 0], "data is not bytes"),
    ],
)
def test_lying_shapes_and_data_are_refused(shape, data, words):
    crafted = frame(array_map("<f4", shape, data))
    if words is None:
        assert unpack(crafted).shape == tuple(shape)
        return
    with pytest.raises(WireError, match=words):
        unpack(crafted)


def test_an_array_map_without_its_fields_is_refused():
    for missing in (b"data", b"dtype", b"shape"):
        full = array_map("<f4", [1], b"\x00" * 4)
        del full[missing]
        with pytest.raises(WireError):
            unpack(frame(full))


def test_a_scalar_value_that_does_not_fit_its_dtype_is_refused():
    for value, spec in ((300, "|u1"), (-1, "<u4"), ("7", "<i8"), (b"\x07", "<i8"), ([7], "<i8"), (2**64 - 1, "<i8")):
        with pytest.raises(WireError, match="numpy scalar"):
            unpack(frame({b"__npgeneric__": True, b"data": value, b"dtype": spec}))


# --- caps -------------------------------------------------------------------------------------


def test_the_caps_are_module_constants_sized_for_four_cameras():
    four_cameras = 4 * 448 * 448 * 3
    assert wire.MAX_ARRAY_BYTES >= four_cameras and wire.MAX_FRAME_BYTES >= 4 * four_cameras
    assert (wire.MAX_ARRAY_BYTES, wire.MAX_FRAME_BYTES, wire.MAX_DEPTH, wire.MAX_ENTRIES) == (64 * 2**20, 256 * 2**20, 32, 10_000)
    cameras = {f"observation/image_{i}": np.zeros((448, 448, 3), np.uint8) for i in range(4)}
    back = unpack(pack({**cameras, "observation/state": np.zeros(8, np.float32), "prompt": "open the drawer"}))
    assert back["observation/image_3"].shape == (448, 448, 3)


def test_an_array_over_the_array_cap_is_refused_and_the_cap_can_be_changed():
    crafted = pack({"a": np.zeros(1000, np.uint8)})
    with pytest.raises(WireError, match=r"shape \(1000,\) and dtype \|u1 is over the cap of 999 bytes"):
        unpack(crafted, max_array_bytes=999)
    assert unpack(crafted, max_array_bytes=1000)["a"].size == 1000


def test_a_frame_over_the_frame_cap_is_refused_before_it_is_parsed():
    crafted = pack({"a": np.zeros(1000, np.uint8)})
    with pytest.raises(WireError, match=f"the frame has {len(crafted)} bytes, over the cap of 1000"):
        unpack(crafted, max_frame_bytes=1000)
    with pytest.raises(WireError, match="over the cap"):
        unpack(b"\xc1" * 1001, max_frame_bytes=1000)  # garbage: the size is checked first
    assert unpack(crafted, max_frame_bytes=len(crafted))["a"].size == 1000


def nested(depth, leaf=0):
    obj = leaf
    for i in range(depth):
        obj = [obj] if i % 2 else {"k": obj}
    return obj


def deep_frame(depth):
    """Lists in lists, deeper than msgpack's packer goes (512)."""
    return b"\x91" * depth + b"\xc0"


def test_nesting_is_capped():
    assert unpack(frame(nested(32))) == nested(32)
    for crafted in (frame(nested(33)), frame(nested(100)), deep_frame(33), deep_frame(1000), deep_frame(5000)):
        with pytest.raises(WireError, match="more than 32 deep"):  # 5000 is past msgpack's own stack (1024)
            unpack(crafted)
    assert unpack(deep_frame(32)) is not None
    with pytest.raises(WireError, match="more than 32 deep"):  # an array's map is one level too
        unpack(frame(nested(32, array_map("<f4", [1], b"\x00" * 4))))
    assert unpack(frame(nested(31, array_map("<f4", [1], b"\x00" * 4)))) is not None
    assert unpack(frame(nested(40)), max_depth=40) == nested(40)
    with pytest.raises(WireError, match="more than 4 deep"):
        unpack(frame(nested(5)), max_depth=4)


def test_maps_and_lists_are_capped_in_entries():
    for big in ({str(i): i for i in range(10_000)}, list(range(10_000))):
        assert unpack(frame({"x": big}))["x"] == big
    for huge in ({str(i): i for i in range(10_001)}, list(range(10_001))):
        with pytest.raises(WireError, match="more than 10000 entries"):
            unpack(frame({"x": huge}))
    with pytest.raises(WireError, match="more than 3 entries"):
        unpack(frame([1, 2, 3, 4]), max_entries=3)
    # a header that claims 4 billion entries in a few bytes
    for header in (b"\xdd\xff\xff\xff\xff", b"\xdf\xff\xff\xff\xff"):
        with pytest.raises(WireError):
            unpack(header + b"\xc0" * 8)


# --- malformed msgpack ------------------------------------------------------------------------


def realistic_frame():
    return pack({
        "observation/image": np.arange(8 * 8 * 3, dtype=np.uint8).reshape(8, 8, 3),
        "observation/state": np.linspace(-1, 1, 8, dtype=np.float32),
        "prompt": "open the drawer",
        "xicm/episode": {"task": "open_drawer", "seed": 0, "episode": 3, "call": np.int64(2)},
    })


def test_every_truncation_of_a_frame_is_refused():
    whole = realistic_frame()
    assert unpack(whole)["prompt"] == "open the drawer"
    for n in range(len(whole)):
        with pytest.raises(WireError):
            unpack(whole[:n])
    with pytest.raises(WireError, match="truncated"):
        unpack(whole[:-1])


@pytest.mark.parametrize(
    "raw, words",
    [
        (b"", "truncated"),
        (b"\xc1", "not valid msgpack"),
        (b"\x01\x02", "bytes after its msgpack value"),
        (b"\xa2\xff\xfe", "not UTF-8"),
        (b"\x81\x01\x02", "not valid msgpack"),  # an integer map key
        (b"\x81\x91\x01\x02", "not valid msgpack"),  # a list as map key
        (b"\xd6\xff\x00\x00\x00\x00", "extension value"),  # a msgpack timestamp
        (b"\xd4\x05\x00", "extension value"),
        (b"\xc7\x0c\xff" + b"\xff" * 12, "not valid msgpack"),  # a timestamp with bad nanoseconds
    ],
)
def test_garbage_msgpack_is_one_wire_error(raw, words):
    with pytest.raises(WireError, match=words):
        unpack(raw)


@pytest.mark.parametrize("value", ["a text frame", None, 5, [b"\x90"]])
def test_a_frame_that_is_not_bytes_is_refused(value):
    with pytest.raises(WireError, match="must be bytes"):
        unpack(value)


def test_bytearray_and_memoryview_frames_decode():
    whole = realistic_frame()
    assert unpack(bytearray(whole))["prompt"] == unpack(memoryview(whole))["prompt"] == "open the drawer"


SPECS = ["|O", "|V8", "<c8", "|S4", "<U1", "<M8[s]", "<m8", "<f4", "|u1", "|b1", ">i2", "<f16", "x", "", "(2,)<f4"]
FUZZ_FRAMES = 12_000


def fuzz_frames(seed=20240532):
    rng = random.Random(seed)
    valid = [realistic_frame(), pack({"actions": np.zeros((4, 8))}), pack([1, {"a": np.int8(3)}, "x"])]
    for i in range(FUZZ_FRAMES):
        kind = i % 4
        if kind == 0:  # random bytes
            yield rng.randbytes(rng.randrange(0, 64))
        elif kind == 1:  # a valid frame with a few bytes changed, inserted or cut
            buf = bytearray(rng.choice(valid))
            for _ in range(rng.randrange(1, 6)):
                op, at = rng.randrange(4), rng.randrange(len(buf))
                if op == 0:
                    buf[at] = rng.randrange(256)
                elif op == 1:
                    buf[at] ^= 1 << rng.randrange(8)
                elif op == 2:
                    buf.insert(at, rng.randrange(256))
                elif len(buf) > 1:
                    del buf[at:at + rng.randrange(1, 8)]
            yield bytes(buf)
        elif kind == 2:  # an array map with chosen dtype, shape and data, each possibly a lie
            spec = rng.choice(SPECS + [rng.randbytes(3).decode("latin-1")])
            shape = [rng.choice([0, 1, 2, 3, 7, -1, 2**31, 2**62]) for _ in range(rng.randrange(0, 4))]
            if rng.random() < 0.1:
                shape = rng.choice([None, "3", 3.0, {"a": 1}, [[1]]])
            data = rng.randbytes(rng.choice([0, 1, 4, 8, 16, 24, 48]))
            if rng.random() < 0.1:
                data = rng.choice(["text", 7, None, [1, 2]])
            tag = rng.choice([b"__ndarray__", b"__npgeneric__"])
            yield frame({"x": {tag: True, b"data": data, b"dtype": spec, b"shape": shape}})
        else:  # a valid frame cut short, or with random bytes behind it
            whole = rng.choice(valid)
            yield whole[: rng.randrange(len(whole))] if rng.random() < 0.5 else whole + rng.randbytes(rng.randrange(1, 9))


def accepted_values_are_plain(obj):
    if isinstance(obj, np.ndarray):
        return obj.dtype.kind in ACCEPTED_KINDS and obj.nbytes <= wire.MAX_ARRAY_BYTES
    if isinstance(obj, np.generic):
        return obj.dtype.kind in ACCEPTED_KINDS
    if isinstance(obj, dict):
        return all(isinstance(k, (str, bytes)) and accepted_values_are_plain(v) for k, v in obj.items())
    if isinstance(obj, list):
        return all(accepted_values_are_plain(v) for v in obj)
    return obj is None or isinstance(obj, (bool, int, float, str, bytes))


def test_fuzzed_frames_decode_or_raise_only_wire_error():
    decoded = refused = 0
    for crafted in fuzz_frames():
        try:
            obj = unpack(crafted)
        except WireError as exc:
            assert str(exc), crafted
            refused += 1
            continue
        except Exception as exc:  # noqa: BLE001 - the point of the test
            pytest.fail(f"{type(exc).__name__} instead of WireError for frame {crafted!r:.200}: {exc}")
        assert accepted_values_are_plain(obj), crafted
        decoded += 1
    assert decoded + refused == FUZZ_FRAMES and refused > FUZZ_FRAMES // 2 and decoded > 0


# --- a real server and client on 127.0.0.1 ----------------------------------------------------


class Echo:
    """Answers {"actions": state * 2}; a reply under "raw" goes out as given (a crafted map)."""

    def __init__(self):
        self.raw_replies = []

    def infer(self, obs):
        if self.raw_replies:
            return self.raw_replies.pop(0)
        return {"actions": np.asarray(obs["state"]) * 2}


@pytest.fixture()
def echo_server():
    srv = PolicyServer(Echo(), host="127.0.0.1", port=0, metadata={"action_dim": 8}).start()
    yield srv
    srv.stop()


OBJECT_ARRAY_FRAME = frame({"state": array_map("|O", [2], np.array([0xDEADBEEF, 8], dtype="<u8").tobytes())})


def test_the_server_answers_bad_frames_with_an_error_and_keeps_serving(echo_server):
    uri = server_uri("127.0.0.1", echo_server.port)
    good = pack({"state": np.ones(3, np.float32)})
    with connect(uri, compression=None, open_timeout=10) as ws:
        assert unpack(ws.recv(timeout=10)) == {"action_dim": 8}
        for bad, words in ((OBJECT_ARRAY_FRAME, "dtype '|O'"), (good[:-3], "truncated"), (b"\xc1\x00", "not valid msgpack"),
                           (frame(nested(40)), "more than 32 deep")):
            ws.send(bad)
            answer = ws.recv(timeout=10)
            assert isinstance(answer, str) and answer.startswith("WireError: ") and words in answer, answer
        ws.send(good)  # the same connection goes on
        np.testing.assert_array_equal(unpack(ws.recv(timeout=10))["actions"], np.full(3, 2, np.float32))
    client = PolicyClient(uri, timeout_s=10)  # and so does a new one
    try:
        np.testing.assert_array_equal(client.infer({"state": np.ones(2)})["actions"], [2.0, 2.0])
    finally:
        client.close()


def test_a_frame_over_the_servers_cap_closes_only_its_connection():
    srv = PolicyServer(Echo(), host="127.0.0.1", port=0, max_frame_bytes=4096).start()
    uri = server_uri("127.0.0.1", srv.port)
    try:
        with connect(uri, compression=None, open_timeout=10) as ws:
            ws.recv(timeout=10)
            ws.send(pack({"state": np.zeros(8192, np.uint8)}))
            with pytest.raises(ConnectionClosed) as closed:
                ws.recv(timeout=10)
            assert closed.value.rcvd is not None and closed.value.rcvd.code == 1009  # message too big
        client = PolicyClient(uri, timeout_s=10)
        try:
            np.testing.assert_array_equal(client.infer({"state": np.ones(2)})["actions"], [2.0, 2.0])
        finally:
            client.close()
    finally:
        srv.stop()


def test_the_client_turns_an_undecodable_reply_into_bad_reply_and_goes_on():
    echo = Echo()
    echo.raw_replies = [{"actions": array_map("|O", [2], b"\x00" * 16)}]  # packs as the crafted map
    srv = PolicyServer(echo, host="127.0.0.1", port=0).start()
    client = PolicyClient(server_uri("127.0.0.1", srv.port), timeout_s=10)
    try:
        with pytest.raises(ServerError, match=r"sent a reply that cannot be decoded \(an array has dtype '\|O'") as err:
            client.infer({"state": np.ones(2)})
        assert err.value.kind == "bad_reply" and str(err.value).count(". ") == 0
        np.testing.assert_array_equal(client.infer({"state": np.ones(2)})["actions"], [2.0, 2.0])
    finally:
        client.close()
        srv.stop()


def test_a_reply_over_the_clients_cap_is_bad_reply_and_the_client_reconnects():
    srv = PolicyServer(Echo(), host="127.0.0.1", port=0).start()
    client = PolicyClient(server_uri("127.0.0.1", srv.port), timeout_s=10, max_frame_bytes=4096)
    try:
        with pytest.raises(ServerError, match="sent a reply over the cap of 4096 bytes") as err:
            client.infer({"state": np.ones(1024)})  # 8 KiB of float64 back
        assert err.value.kind == "bad_reply"
        np.testing.assert_array_equal(client.infer({"state": np.ones(2)})["actions"], [2.0, 2.0])
    finally:
        client.close()
        srv.stop()


def small_observation():
    frame_ = CameraFrame(rgb=np.zeros((8, 8, 3), np.uint8), depth=None, segmentation=None,
                         intrinsic=np.eye(3), cam_to_world=np.eye(4))
    return Observation(
        instruction="open the drawer", cameras={"front": frame_}, segment_names={}, object_names=[],
        gripper=KeyAction((0.0, 0.0, 1.0), (1.0, 0.0, 0.0, 0.0), True), joint_positions=np.zeros(7),
        proprio={"joint_positions": np.zeros(7), "gripper_width": np.zeros(1)},
    )


def test_policy_remote_fails_the_step_with_bad_reply_and_the_next_call_is_answered():
    good = {"actions": np.array([[0.1, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 1.0]])}

    class Scripted:
        def __init__(self):
            self.replies = [{"actions": array_map("|O", [1, 8], b"\x00" * 64)}, good]

        def infer(self, obs):
            return self.replies.pop(0)

    srv = PolicyServer(Scripted(), port=0).start()
    client = PolicyClient(server_uri("127.0.0.1", srv.port), timeout_s=10)
    client.connect()
    # a spec of its own (no simulator here): key poses, and the two proprio fields the request sends
    spec = ControlSpec(modes=(key_pose_mode(((-1, -1, 0), (1, 1, 2))),),
                       state=(layout("joint_positions", range(7), [-3] * 7, [3] * 7), layout("gripper_width", "w", [0], [0.1])))
    policy = RemotePolicy(client, {**dataclasses.asdict(RemotePolicyOptions()), "control_mode": "key_pose"}, spec)
    try:
        with pytest.raises(EpisodeFailure) as failure:
            policy.act(small_observation())
        assert failure.value.kind == "bad_reply" and "dtype '|O'" in failure.value.message
        assert len(policy.act(small_observation())) == 1
    finally:
        client.close()
        srv.stop()
