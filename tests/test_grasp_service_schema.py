"""The grasp service fuzzed from its own OpenAPI schema with schemathesis: generated bodies (valid and invalid
against the schema) for /process, /process_npz and /health never get a 5xx, and every answer conforms to the
documented status codes, content types and response schemas."""

from __future__ import annotations

import collections
import os

import pytest

pytest.importorskip("fastapi")
schemathesis = pytest.importorskip("schemathesis")
from hypothesis import HealthCheck, settings  # noqa: E402

from ferrobot.grasp.server import ServiceLimits, create_app  # noqa: E402

MiB = 1024 * 1024
# Small images keep each generated request fast; the schema states these limits (maxItems), so generation
# explores the edges.
APP = create_app(limits=ServiceLimits(max_body_bytes=MiB, max_json_bytes=MiB, max_image_side=16))
# A body that breaks the schema must get a 4xx: 413 when it breaks a size bound (maxItems of an image), 400/422
# otherwise (schemathesis's default list lacks 413).
CONFIG = schemathesis.Config.from_dict(
    {
        "checks": {
            "negative_data_rejection": {"expected-statuses": ["400", "413", "415", "422"]},
            # A schema cannot state everything the detector checks (rectangular images, colours and mask shaped
            # like the depth image, lims min <= max, depths below finger_depth): a schema-valid body may still be
            # refused, with a 4xx naming the problem, so positive-data acceptance is not asserted.
            "positive_data_acceptance": {"enabled": False},
        }
    }
)
schema = schemathesis.openapi.from_asgi("/openapi.json", APP, config=CONFIG)
#: Examples per operation and phase: 100 in the test suite, more for a longer run (BENCHMARKS.md):
#: ``FERROBOT_FUZZ_EXAMPLES=2000 pytest tests/test_grasp_service_schema.py -s``.
EXAMPLES = int(os.environ.get("FERROBOT_FUZZ_EXAMPLES", "100"))
RUNS: collections.Counter = collections.Counter()


@pytest.fixture(scope="module", autouse=True)
def _report_runs():
    yield
    print(f"\nschemathesis requests per operation: {dict(RUNS)}; total {sum(RUNS.values())}")


@schema.parametrize()
@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=list(HealthCheck), derandomize=True)
def test_service_conforms_to_its_schema(case):
    RUNS[case.operation.label] += 1
    case.call_and_validate()
