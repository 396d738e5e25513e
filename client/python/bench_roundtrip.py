#!/usr/bin/env python3
"""Round-trip time of feature-set requests from the Python client, to set beside the C++
client's `sceneloc bench --features` (client/load_generator.cc).

Sends the same feature-set file (`sceneloc extract IMAGE --map-file MAP --out FILE`) to a
server N times, one request after another on one connection, after some warm-up requests,
and prints the median (p50) and p99 round trip in milliseconds (nearest rank, as `sceneloc
bench` computes them) and the server's own time. As in `sceneloc bench`, the feature set is
encoded into its wire bytes once, before the clock; a timed call is
client.localise_features: the request serialised with those bytes appended, sent, answered,
parsed and read into a sceneloc.LocaliseReply. --encode-each also times what a robot
extracting its own features pays: the FeatureSet encoded from its numpy arrays every call.

    bench_roundtrip.py --server tcp://127.0.0.1:5555 --map demo --features f.pb [-n 200]

Needs the installed sceneloc package. Exit status 0, 1 if a request failed, 2 for bad
arguments or an unreadable file.
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from typing import Sequence, Union

import sceneloc


def quantile(values: Sequence[float], q: float) -> float:
    """The nearest-rank quantile (client/load_generator.cc Quantile)."""
    ordered = sorted(values)
    return ordered[max(1, math.ceil(q * len(ordered))) - 1]


def parse_args(argv: Sequence[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--server", required=True, help="endpoint, e.g. tcp://127.0.0.1:5555")
    parser.add_argument("--map", required=True, help="map name")
    parser.add_argument("--features", required=True, help="feature-set file (sceneloc extract)")
    parser.add_argument("-n", "--requests", type=int, default=200, help="timed requests (200)")
    parser.add_argument("--warmup", type=int, default=10, help="untimed requests first (10)")
    parser.add_argument("--timeout-ms", type=int, default=10000, help="per attempt (10000)")
    parser.add_argument("--encode-each", action="store_true",
                        help="encode the FeatureSet from its arrays on every call")
    args = parser.parse_args(argv)
    if args.requests < 1 or args.warmup < 0:
        parser.error("--requests must be >= 1 and --warmup >= 0")
    return args


def main(argv: Sequence[str]) -> int:
    args = parse_args(argv)
    try:
        feature_set = sceneloc.FeatureSet.from_file(args.features)
    except (OSError, ValueError) as e:
        print(f"bench_roundtrip: {e}", file=sys.stderr)
        return 2
    features: Union[sceneloc.FeatureSet, bytes] = (
        feature_set if args.encode_each else feature_set.to_bytes()  # once, as sceneloc bench
    )
    round_trip_ms: list[float] = []
    server_ms: list[float] = []
    with sceneloc.Client(args.server, timeout_ms=args.timeout_ms, retries=0,
                         overload_wait_ms=0) as client:
        try:
            for i in range(args.warmup + args.requests):
                start = time.perf_counter()
                reply = client.localise_features(args.map, features)
                elapsed_ms = (time.perf_counter() - start) * 1000
                if i >= args.warmup:
                    round_trip_ms.append(elapsed_ms)
                    server_ms.append(reply.timings.total_ms)
        except sceneloc.SceneLocError as e:
            print(f"bench_roundtrip: request {i + 1}: {e}", file=sys.stderr)
            return 1
    mode = "encoded on every call" if args.encode_each else "encoded once"
    print(f"bench_roundtrip: {args.server}, map {args.map}, {args.features} "
          f"({len(feature_set)} features, {mode}), {args.requests} requests after "
          f"{args.warmup} warm-up")
    # Outside the server, request by request (as `sceneloc bench`'s outside_ms).
    outside_ms = [trip - server for trip, server in zip(round_trip_ms, server_ms)]
    for label, values in (("round trip ms", round_trip_ms), ("server ms", server_ms),
                          ("outside ms", outside_ms)):
        print(f"{label:<14} median {quantile(values, 0.5):.2f}  p99 {quantile(values, 0.99):.2f}"
              f"  max {max(values):.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
