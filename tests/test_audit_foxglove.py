"""What Foxglove needs to open the monitor's logs: JSON channels with valid JSON Schemas their messages satisfy."""

from __future__ import annotations

import json
import re

import jsonschema
import pytest
from mcap.reader import make_reader

from tests.audit_logs import monitor_logs

TOPIC = re.compile(r"^/discern/(status|[A-Za-z0-9_\-]+/(proposal|verdict|rejected))$")


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    return monitor_logs(tmp_path_factory)


def test_every_channel_is_json_with_a_json_schema_its_messages_satisfy(logs):
    seen_topics = set()
    for path in logs.values():
        with open(path, "rb") as f:
            reader = make_reader(f)
            summary = reader.get_summary()
            assert summary is not None and summary.statistics.message_count > 0  # indexed: Foxglove can seek
            validators = {}
            for schema, channel, message in reader.iter_messages():
                seen_topics.add(channel.topic)
                assert TOPIC.match(channel.topic), channel.topic
                assert channel.message_encoding == "json" and schema.encoding == "jsonschema"
                if channel.id not in validators:
                    document = json.loads(schema.data)
                    jsonschema.Draft202012Validator.check_schema(document)
                    validators[channel.id] = jsonschema.Draft202012Validator(document)
                errors = list(validators[channel.id].iter_errors(json.loads(message.data)))
                assert errors == [], f"{channel.topic}: {errors[0].message}"
    assert {
        "/discern/car_a/proposal",
        "/discern/car_a/verdict",
        "/discern/car_b/rejected",
        "/discern/status",
    } <= seen_topics
