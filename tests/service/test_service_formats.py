"""Pure pieces of the service: SPARQL content negotiation and ROS durations (no server)."""

import pytest

from hriplan.formats.ros_trajectory import RosTime
from hriplan.service.negotiation import NotAcceptable, choose


@pytest.mark.parametrize(
    ("graph", "accept", "fmt", "expected"),
    [
        (False, None, None, ("json", "application/sparql-results+json")),
        (False, "*/*", None, ("json", "application/sparql-results+json")),
        (False, "text/csv;q=0.5, text/tab-separated-values", None, ("tsv", "text/tab-separated-values")),
        (
            False,
            "application/sparql-results+xml;q=0.9, application/json;q=0.8",
            None,
            ("xml", "application/sparql-results+xml"),
        ),
        (False, "text/*", None, ("csv", "text/csv")),
        (False, "text/turtle, application/json;q=0.1", None, ("json", "application/json")),
        (True, None, None, ("turtle", "text/turtle")),
        (True, "application/json", None, ("json-ld", "application/json")),
        (True, "application/ld+json;q=0.2, text/turtle;q=0.3", None, ("turtle", "text/turtle")),
        (True, "text/csv", "turtle", ("turtle", "text/turtle")),
        (False, "text/turtle", "json", ("json", "application/sparql-results+json")),
    ],
)
def test_the_best_accepted_syntax_that_can_carry_the_result_wins(graph, accept, fmt, expected):
    assert choose(graph, accept, fmt) == expected


def test_unacceptable_requests_name_what_is_offered():
    with pytest.raises(
        NotAcceptable, match=r"none of the accepted types \(text/turtle\) .*offered: application/sparql-results\+json, "
    ):
        choose(False, "text/turtle")
    with pytest.raises(NotAcceptable, match="format=csv cannot carry this result; use one of turtle, json-ld, nt"):
        choose(True, None, "csv")
    with pytest.raises(NotAcceptable):
        choose(False, "text/csv;q=0")


@pytest.mark.parametrize(
    ("seconds", "sec", "nanosec"),
    [
        (0.0, 0, 0),
        (1.5, 1, 500_000_000),
        (0.9999999999, 1, 0),
        (2.000000001, 2, 1),
        (12.3456789012, 12, 345_678_901),
    ],
)
def test_durations_are_whole_seconds_and_nanoseconds(seconds, sec, nanosec):
    assert RosTime.of(seconds).model_dump() == {"sec": sec, "nanosec": nanosec}
