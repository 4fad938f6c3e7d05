#!/usr/bin/env python3
"""Writes the seed corpora of tests/fuzz/corpus/<target>/ for the targets that have no hand-made
corpus (decision 1401): config, rest, rest_body, ws_query, http_request, transport, linmot_linudp,
linmot_mc, linmot_curve, stober, parameter_set, curve_set.

Seeds come from the inputs the unit tests use: string literals, raw strings and byte lists are
read out of the named test sources (and the shipped example configs), then framed the way each
fuzz target reads its input (a mode byte where the target has one). Deterministic: the same tree
gives the same files. A generated file is named gen_<source>_<n>; hand-made or fuzzer-found
regression inputs (names without the gen_ prefix) are kept when the script rewrites a corpus.

  tests/fuzz/gen_corpus.py            rewrite the gen_* files of every corpus above
  tests/fuzz/gen_corpus.py --check    exit 1 if a committed corpus differs from what it makes
"""
import hashlib
import pathlib
import re
import struct
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
CORPUS = ROOT / "tests" / "fuzz" / "corpus"


def src(path):
    return (ROOT / path).read_text(encoding="utf-8")


def strip_comments(text):
    return re.sub(r"//[^\n]*", "", text)


_ESC = {"n": "\n", "t": "\t", "r": "\r", '"': '"', "\\": "\\", "'": "'", "0": "\0"}


def unescape(s):
    out, i = [], 0
    while i < len(s):
        c = s[i]
        if c == "\\" and i + 1 < len(s):
            e = s[i + 1]
            if e == "x":
                m = re.match(r"[0-9A-Fa-f]{1,2}", s[i + 2:])
                out.append(chr(int(m.group(0), 16)))
                i += 2 + len(m.group(0))
                continue
            out.append(_ESC.get(e, e))
            i += 2
            continue
        out.append(c)
        i += 1
    return "".join(out)


def raw_strings(text):
    """The contents of every C++ raw string literal R"d(...)d"."""
    return [m.group(2) for m in re.finditer(r'R"(\w*)\((.*?)\)\1"', text, re.S)]


def string_literals(text):
    """Every ordinary "..." literal (adjacent literals joined), unescaped."""
    text = re.sub(r'R"(\w*)\((.*?)\)\1"', "", text, flags=re.S)
    text = strip_comments(text)
    out = []
    for m in re.finditer(r'"((?:[^"\\\n]|\\.)*)"(?:\s*"((?:[^"\\\n]|\\.)*)")*', text):
        parts = re.findall(r'"((?:[^"\\\n]|\\.)*)"', m.group(0))
        out.append(unescape("".join(parts)))
    return out


def byte_lists(text, min_len=2):
    """Every brace list of byte literals ({0x01, 0x02, 3}) in the source."""
    out = []
    for m in re.finditer(r"\{([^{}]*)\}", strip_comments(text)):
        items = [t.strip() for t in m.group(1).split(",") if t.strip()]
        if len(items) < min_len:
            continue
        try:
            values = [int(t, 0) for t in items]
        except ValueError:
            continue
        if all(0 <= v <= 255 for v in values):
            out.append(bytes(values))
    return out


def unique(items):
    seen, out = set(), []
    for b in items:
        if b not in seen:
            seen.add(b)
            out.append(b)
    return out


# ---- msgpack (the python-can udp_multicast message, adapters/transport/udp_multicast_channel) --
def mp(v):
    if isinstance(v, bool):
        return b"\xc3" if v else b"\xc2"
    if isinstance(v, int):
        if 0 <= v < 128:
            return bytes([v])
        if 0 <= v < 1 << 32:
            return b"\xce" + struct.pack(">I", v)
        return b"\xd3" + struct.pack(">q", v)
    if isinstance(v, float):
        return b"\xcb" + struct.pack(">d", v)
    if isinstance(v, str):
        b = v.encode()
        return (bytes([0xA0 | len(b)]) if len(b) < 32 else b"\xd9" + bytes([len(b)])) + b
    if isinstance(v, bytes):
        return b"\xc4" + bytes([len(v)]) + v
    if isinstance(v, dict):
        out = bytes([0x80 | len(v)])
        for k, x in v.items():
            out += mp(k) + mp(x)
        return out
    raise TypeError(v)


def python_can(arb, data, ext=False, rtr=False, err=False, ts=1700000000.5):
    return mp({"timestamp": ts, "arbitration_id": arb, "is_extended_id": ext,
               "is_remote_frame": rtr, "is_error_frame": err, "dlc": len(data), "data": data,
               "is_fd": False, "is_rx": True})


# ---- LinMot curve info block (decision 706 offsets; adapters/linmot/linudp/curve_info_block.h) --
def info_block(points, curve_id=1, x_length=50000, name=b"drivegw", wizard=0x4744,
               offset=0, amplitude=1000, time_scale=10000):
    b = struct.pack("<HHHH", 70, 0x0003, points, 4) + name.ljust(22, b"\0")[:22]
    b += struct.pack("<HIHHHiiI", curve_id, x_length, 0x001A, 0x0005, wizard, offset, amplitude,
                     time_scale)
    return b.ljust(70, b"\0")


def rtc_reply(status, w2=0, w3=0, w4=0, count=1):
    return struct.pack("<BBHHHx", count, status, w2, w3, w4)[:8]


def upload_script(points, info=None):
    """The RTC replies of a successful CurveService::Upload (0x60, 0x61 x 18, 0x62 per point)."""
    info = info or info_block(len(points))
    out = rtc_reply(0x00, 1, 70, 4 * len(points))
    for at in range(0, 70, 4):
        chunk = info[at:at + 4].ljust(4, b"\0")
        out += rtc_reply(0x04, 1, chunk[0] | chunk[1] << 8, chunk[2] | chunk[3] << 8)
    for p in points:
        u = p & 0xFFFFFFFF
        out += rtc_reply(0x04, 1, u & 0xFFFF, u >> 16)
    return out


# ---- corpora --------------------------------------------------------------------------------
def config_seeds():
    seeds = []
    for path in ["docker/drivegw.yaml", "docker/gateway.yaml"]:
        seeds.append((pathlib.Path(path).stem, src(path).encode()))
    for path in ["tests/server/config/config_test.cpp", "tests/server/config/stober_config_test.cpp",
                 "tests/server/config/trinamic_config_test.cpp",
                 "tests/server/config/env_overrides_test.cpp"]:
        text = src(path)
        name = pathlib.Path(path).stem
        docs = raw_strings(text) + [s for s in string_literals(text) if ":" in s and "\n" in s]
        seeds += [(name, d.encode()) for d in docs]
    return seeds


def rest_paths():
    paths = []
    for path in ["tests/server/rest/router_test.cpp", "tests/server/rest/router_bindings_test.cpp",
                 "tests/server/rest/direct_reads_test.cpp", "tests/server/rest/server_test.cpp",
                 "tests/server/rest/path_template_test.cpp"]:
        paths += [s for s in string_literals(src(path)) if s.startswith("/") and " " not in s]
    return unique(p.encode() for p in paths)


def rest_seeds():
    # rest_fuzz puts "/" in front: the seeds are paths without it (and the templates as text).
    return [("router_test", p[1:]) for p in rest_paths()]


def rest_body_seeds():
    text = src("tests/server/rest/router_test.cpp") + src("tests/server/rest/router_bindings_test.cpp")
    bodies = unique(s.encode() for s in string_literals(text) + raw_strings(text)
                    if s.lstrip().startswith(("{", "[", '"')) or s.strip() in ("", "1", "true"))
    seeds = []
    # Rendered routes (mode 0..63): every body on the first routes, route index cycling.
    for i, body in enumerate(bodies):
        for route in (i % 64, (i * 7 + 3) % 64):
            seeds.append(("router_test", bytes([route]) + b"\n" + body))
    # Query strings on rendered routes.
    queries = [b"validate_only=true", b"names=x1&names=x2&max_rate_hz=10", b"page_size=5",
               b"view=FULL", b"parameter.id=7&parameter.rom=true", b"filter=%41%2",
               b"a.b.c=1", b"name=drives%2Fx1"]
    for i, q in enumerate(queries):
        seeds.append(("router_test", bytes([i * 5 % 64 | 0x40]) + q + b"\n"))
    # Raw targets (mode bit 7) with the four methods.
    for i, p in enumerate(rest_paths()):
        seeds.append(("router_test", bytes([0x80 | (i % 4)]) + p + b"\n{}"))
    return seeds


def ws_query_seeds():
    text = src("tests/server/web/ws_query_test.cpp") + src("tests/server/web/ws_gateway_test.cpp")
    targets = [s for s in string_literals(text) if s.startswith("/v1/drives:ws")]
    targets += ["/v1/drives:ws?access_token=dgw_abc.def&names=x%2C1,x2&max_rate_hz=0.5",
                "/v1/drives:ws?names=%E2%82%AC&names=+a+", "/v1/drives:ws?max_rate_hz=%zz"]
    return [("ws_query_test", t.encode()) for t in unique(targets)]


def http_request_seeds():
    """Whole requests as clients send them (split byte first: 0 = one read), from the REST
    server tests' raw requests and client calls, with Authorization variants ("@TOKEN@" is the
    fuzz target's live token)."""
    text = strip_comments(src("tests/server/rest/server_test.cpp"))
    raw = [s for s in string_literals(text) if "\r\n" in s and " " in s]
    paths = [p.decode() for p in rest_paths()[:24]]
    auths = ["", "Bearer @TOKEN@", "bearer   @TOKEN@", "Bearer @TOKEN@x", "Basic YWxhZGRpbjpv",
             "Bearer dgw_0123456789abcdef_AAAA", "Bearer", "Bearer dgw_", "BEARER @TOKEN@ "]
    reqs = list(raw)
    for i, path in enumerate(paths):
        auth = auths[i % len(auths)]
        head = f"GET {path} HTTP/1.1\r\nHost: gw\r\n"
        if auth:
            head += f"Authorization: {auth}\r\n"
        reqs.append(head + "\r\n")
    body = '{"position_mm": 10, "velocity_mm_s": 10, "acceleration_mm_s2": 100}'
    for auth in auths:
        reqs.append(f"POST /v1/drives/x1:moveAbsolute HTTP/1.1\r\nHost: gw\r\n"
                    f"Authorization: {auth}\r\nContent-Type: application/json\r\n"
                    f"Content-Length: {len(body)}\r\n\r\n{body}")
    reqs += ["POST /v1/parameterSets HTTP/1.1\r\nHost: gw\r\nTransfer-Encoding: chunked\r\n\r\n"
             "4\r\n{}  \r\n0\r\n\r\n",
             "POST /v1/curveSets HTTP/1.1\r\nContent-Length: 2000000\r\n\r\n{}",
             "GET / HTTP/1.1\r\nX-Big: " + "a" * 17000 + "\r\n\r\n",
             "GET /v1/drives HTTP/1.1\r\nHost: gw\r\n\r\nGET /v1/drives HTTP/1.1\r\n\r\n",
             "GET /v1/drives HTTP/1.0\r\n\r\n",
             "GET /v1/drives:ws HTTP/1.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
             "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n"]
    seeds = []
    for i, r in enumerate(unique(reqs)):
        data = r.encode("latin-1")
        seeds.append(("server_test", bytes([0]) + data))
        if len(data) > 8:  # the same request in two reads, split inside the head
            seeds.append(("server_test", bytes([(i * 37 + 5) % 251 + 1]) + data))
    return seeds


def transport_seeds():
    seeds = []
    frames = [(0x605, bytes.fromhex("4041600000000000")), (0x185, bytes.fromhex("3706a08601")),
              (0x1ABCDEF0, bytes(range(1, 9))), (0x000, b"\x01\x05"), (0x705, b"\x05")]
    for i, (arb, data) in enumerate(frames):
        seeds.append(("udp_multicast", b"\x00" + python_can(arb, data, ext=arb > 0x7FF)))
    seeds.append(("udp_multicast", b"\x00" + python_can(0x7FF, b"", rtr=True)))
    seeds.append(("udp_multicast", b"\x02" + python_can(0x123, b"\xaa\xbb")))
    seeds.append(("overlay", b"\x01\x03\x10\x07\x22"))
    text = src("tests/adapters/transport/can/candump_trace_test.cpp")
    for s in string_literals(text):
        if s.startswith("("):
            seeds.append(("candump_trace_test", b"\x03" + s.encode()))
    seeds.append(("overlay", b"\x04\x05\x41\x09\x23"))
    text = src("tests/adapters/transport/can/can_bit_timing_test.cpp")
    for s in string_literals(text):
        if s.startswith(("udp", "socketcan", "vcan", "can")):
            seeds.append(("can_bit_timing_test", b"\x05" + s.encode()))
    return seeds


def linmot_linudp_seeds():
    text = src("tests/adapters/linmot/linudp/codec_test.cpp")
    return [("codec_test", b) for b in unique(byte_lists(text, 8))]


def linmot_mc_seeds():
    text = src("tests/adapters/linmot/mc/motion_command_test.cpp")
    return [("motion_command_test", b) for b in unique(byte_lists(text, 2))]


def linmot_curve_seeds():
    pts2 = [0, 10000]
    pts5 = [0, 2500, 10000, -7500, 2147483647]
    seeds = [("curve_service_test", bytes([0]) + info_block(2)),
             ("curve_service_test", bytes([0]) + info_block(3, 100, 4294967295, b"x" * 22)),
             ("curve_service_test", bytes([1]) + struct.pack("<5i", *pts5)),
             ("curve_service_test", bytes([2]) + info_block(2) + struct.pack("<2i", *pts2)),
             ("curve_service_test", bytes([2]) + info_block(5, 7, 123456, b"press", 0, -5000, -20000,
                                                             20000) + struct.pack("<5i", *pts5)),
             ("curve_service_test", bytes([3]) + upload_script(pts2)),
             ("curve_service_test", bytes([3]) + upload_script(pts5)),
             ("curve_service_test", bytes([3]) + rtc_reply(0xD4)),
             ("curve_service_test", bytes([3]) + rtc_reply(0x00, 1, 70, 8) + rtc_reply(0xC2))]
    # Upload, then a download answered block by block (0x50 accepted, 18 info blocks and the first
    # point 0x04, the last point 0x00) and its read-back.
    download = rtc_reply(0x00) + rtc_reply(0x04) * 18 + rtc_reply(0x04) + rtc_reply(0x00)
    seeds.append(("curve_service_test", bytes([3]) + upload_script(pts2) + download +
                  upload_script(pts2, info_block(2, 2, 50000))))
    return seeds


def stober_seeds():
    seeds = []
    # TPDO payloads (mode 0): status word 6041h, I89, I90, packed flags; position/velocity.
    tpdos = [bytes.fromhex("3702") + b"\x00\x00" + struct.pack("<I", 0x2), bytes.fromhex("3706"),
             struct.pack("<ii", 100000, -2500), bytes.fromhex("0806000000000000"), b""]
    seeds += [("object_map_test", b"\x00" + t) for t in tpdos]
    # SDO values (mode bit 7, bytes 0-1 = binding index): 1, 2 and 4 bytes for the first bindings.
    for i in range(48):
        for n in (1, 2, 4):
            value = bytes((i * 37 + k * 11) & 0xFF for k in range(n))
            seeds.append(("object_map_test", bytes([0x80 | (i >> 8), i & 0xFF]) + value))
    return seeds


def parameter_set_seeds():
    text = src("tests/server/parameter_sets/parameter_set_io_test.cpp")
    seeds = []
    for s in raw_strings(text) + string_literals(text):
        t = s.lstrip()
        if t.startswith("{"):
            seeds.append(("parameter_set_io_test", b"\x00" + s.encode()))
        elif "," in s and ("parameter" in s.lower() or "\n" in s):
            seeds.append(("parameter_set_io_test", b"\x01" + s.encode()))
    seeds.append(("parameter_set_io_test", b"\x01parameter,value\n# c\nI10,0x10\r\n$14.vmax,-0x7\n"))
    return unique_pairs(seeds)


def curve_set_seeds():
    text = src("tests/server/curve_sets/curve_set_io_test.cpp") + src(
        "tests/server/curve_sets/curve_set_service_test.cpp")
    seeds = [("curve_set_test", s.encode()) for s in raw_strings(text) + string_literals(text)
             if s.lstrip().startswith("{")]
    seeds += [("curve_set", s.encode()) for s in [
        '{"name":"curveSets/press","curves":[{"name":"a","positionTime":{"timeStepS":0.01,'
        '"positionsMm":[0,1,2.5,4]}}]}',
        '{"curves":[{"name":"l","linmot":{"curveId":3,"xLengthS":0.5,"points":[0,10000,5000],'
        '"offsetMm":1.5,"amplitudeScalePct":50,"timeScalePct":200}}]}',
        '{"curves":[{"name":"bad","positionTime":{"timeStepS":0,"positionsMm":[1]}},'
        '{"name":"n","linmot":{"curveId":101}}]}']]
    return unique_pairs(seeds)


def unique_pairs(seeds):
    seen, out = set(), []
    for name, b in seeds:
        if b not in seen:
            seen.add(b)
            out.append((name, b))
    return out


TARGETS = {
    "config": config_seeds,
    "rest": rest_seeds,
    "rest_body": rest_body_seeds,
    "ws_query": ws_query_seeds,
    "http_request": http_request_seeds,
    "transport": transport_seeds,
    "linmot_linudp": linmot_linudp_seeds,
    "linmot_mc": linmot_mc_seeds,
    "linmot_curve": linmot_curve_seeds,
    "stober": stober_seeds,
    "parameter_set": parameter_set_seeds,
    "curve_set": curve_set_seeds,
}


def generate(target):
    files = {}
    for name, data in unique_pairs(TARGETS[target]()):
        digest = hashlib.sha1(data).hexdigest()[:10]
        files[f"gen_{name}_{digest}"] = data
    return files


def main():
    check = "--check" in sys.argv[1:]
    differs = False
    for target in TARGETS:
        d = CORPUS / target
        want = generate(target)
        if not want:
            sys.exit(f"gen_corpus: no seeds for {target}")
        have = {p.name: p.read_bytes() for p in d.glob("gen_*")} if d.is_dir() else {}
        if check:
            if have != want:
                print(f"gen_corpus: corpus/{target} differs from the generator", file=sys.stderr)
                differs = True
            continue
        d.mkdir(parents=True, exist_ok=True)
        for name in set(have) - set(want):
            (d / name).unlink()
        for name, data in want.items():
            (d / name).write_bytes(data)
        print(f"corpus/{target}: {len(want)} generated seeds")
    sys.exit(1 if differs else 0)


if __name__ == "__main__":
    main()
