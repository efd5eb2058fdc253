#!/usr/bin/env python3
"""Check a hystid MCAP run file with the official Python reader.

Usage: check_mcap.py RUN.mcap EXPECT.json

EXPECT.json holds
  "counts":      {topic: number of messages}
  "first_block": the first /hystid/signals message's fields (step, first_frame,
                 t0, fs and the four float32 arrays, as exact numbers)
  "metadata":    {record name: {key: value}}
  "attachment":  text of the test.toml attachment

The file is opened with make_reader(f, validate_crcs=True); every message is
read (JSON decoded, CDR decoded with mcap-ros2-support), log times must never
decrease. Prints OK and exits 0 when everything matches, else prints each
mismatch and exits 1. Exits 2 if the mcap packages are missing.
"""

import json
import struct
import sys

try:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
except ImportError as e:  # pragma: no cover
    print(f"SKIPPED: python mcap reader not installed ({e})")
    sys.exit(2)


def f32(x):
    """x rounded to float32, as Python float."""
    return struct.unpack("<f", struct.pack("<f", x))[0]


def main(run_path, expect_path):
    with open(expect_path) as f:
        expect = json.load(f)
    problems = []

    with open(run_path, "rb") as f:
        reader = make_reader(f, validate_crcs=True)
        cdr = DecoderFactory()
        decoders = {}
        summary = reader.get_summary()
        if summary is None or summary.statistics is None:
            problems.append("no summary statistics")
        else:
            by_topic = {}
            for cid, n in summary.statistics.channel_message_counts.items():
                topic = summary.channels[cid].topic
                by_topic[topic] = by_topic.get(topic, 0) + n
            if by_topic != expect["counts"]:
                problems.append(f"statistics counts {by_topic} != {expect['counts']}")

        counts = {}
        last_time = -1
        first_block = None
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
            if message.log_time < last_time:
                problems.append(f"log time goes back at {channel.topic} {message.log_time}")
            last_time = message.log_time
            if channel.message_encoding == "json":
                if not isinstance(json.loads(message.data), dict):
                    problems.append(f"{channel.topic}: a JSON message is not an object")
            elif channel.topic == "/hystid/signals":
                if schema.name != "hystid_msgs/msg/SignalBlock" or schema.encoding != "ros2msg":
                    problems.append(f"signal schema {schema.name} {schema.encoding}")
                if schema.id not in decoders:
                    decoders[schema.id] = cdr.decoder_for(channel.message_encoding, schema)
                block = decoders[schema.id](message.data)
                if first_block is None:
                    first_block = block
        if counts != expect["counts"]:
            problems.append(f"messages read {counts} != {expect['counts']}")

        want = expect["first_block"]
        if first_block is None:
            problems.append("no /hystid/signals message")
        else:
            for key in ("step", "first_frame", "t0", "fs"):
                got = getattr(first_block, key)
                if got != want[key]:
                    problems.append(f"first block {key}: {got} != {want[key]}")
            for key in ("force", "displacement", "velocity", "acceleration"):
                got = list(getattr(first_block, key))
                exp = [f32(v) for v in want[key]]
                if len(got) != len(exp):
                    problems.append(f"first block {key}: {len(got)} samples != {len(exp)}")
                    continue
                bad = [i for i, (g, e) in enumerate(zip(got, exp)) if g != e]
                if bad:
                    i = bad[0]
                    problems.append(f"first block {key}[{i}]: {got[i]!r} != {exp[i]!r} ({len(bad)} differ)")

        metadata = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
        for name, want_map in expect["metadata"].items():
            if metadata.get(name) != want_map:
                problems.append(f"metadata {name}: {metadata.get(name)} != {want_map}")
        attachments = {a.name: a.data for a in reader.iter_attachments()}
        text = attachments.get("test.toml", b"").decode("utf-8")
        if text != expect["attachment"]:
            problems.append(f"attachment test.toml: {text!r} != {expect['attachment']!r}")

    for p in problems:
        print("MISMATCH:", p)
    if problems:
        return 1
    print(f"OK: {sum(counts.values())} messages, CRCs valid, first block matches")
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 3:
        print(__doc__)
        sys.exit(2)
    sys.exit(main(sys.argv[1], sys.argv[2]))
