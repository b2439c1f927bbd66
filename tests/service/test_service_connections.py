"""Slow and idle clients against a real server on loopback (issue 22): a bounded number of open
connections (more are answered 503 and closed), a deadline for a request's head and body, and
no log line per refused socket (before: 1100 idle sockets locked every client out and wrote
129 MB of tracebacks)."""

import socket
import tempfile

import httpx
import pytest
from service_server import running_server

CAP, IDLE = 20, 120


@pytest.fixture(scope="module")
def served():
    log = tempfile.TemporaryFile(mode="w+")
    args = ("--workers", "1", "--max-connections", str(CAP), "--header-timeout", "2", "--body-timeout", "2")
    with running_server(*args, log=log) as url:
        yield url, log
    log.close()


def _address(url: str) -> tuple[str, int]:
    host, port = url.removeprefix("http://").split(":")
    return host, int(port)


def test_idle_sockets_beyond_the_cap_are_refused_and_the_rest_time_out(served):
    url, log = served
    sockets = [socket.create_connection(_address(url)) for _ in range(IDLE)]
    answers = []
    for s in sockets:
        s.settimeout(30)  # the head deadline is 2 s: every socket is answered or closed well before
        answers.append(s.recv(4096))
        s.close()
    refused = [a for a in answers if a.startswith(b"HTTP/1.1 503")]
    closed = [a for a in answers if a == b""]
    assert len(refused) + len(closed) == IDLE and IDLE - CAP <= len(refused) < IDLE
    assert b"as many connections open as it allows" in refused[0] and b"retry-after: 1" in refused[0]
    health = httpx.get(f"{url}/health")  # the idle ones were closed: clients get in again
    assert health.status_code == 200
    log.seek(0)
    text = log.read()
    assert "Traceback" not in text and len(text) < 10_000


def test_a_body_that_does_not_arrive_is_408(served):
    url, _ = served
    with socket.create_connection(_address(url)) as s:
        host, port = _address(url)
        s.sendall(
            f"POST /constraints HTTP/1.1\r\nhost: {host}:{port}\r\ncontent-type: application/json\r\n"
            'content-length: 100\r\n\r\n{"steps":'.encode()
        )
        s.settimeout(30)
        answer = b""
        while b"}" not in answer.split(b"\r\n\r\n", 1)[-1]:
            chunk = s.recv(4096)
            if not chunk:
                break
            answer += chunk
    assert answer.startswith(b"HTTP/1.1 408") and b"the request body did not arrive within 2 s" in answer


def test_a_head_sent_slowly_is_cut_off(served):
    url, _ = served
    host, port = _address(url)
    with socket.create_connection((host, port)) as s:
        s.sendall(b"GET /health HTTP/1.1\r\nhost: ")  # and never the rest
        s.settimeout(30)
        assert s.recv(4096) == b""  # closed at the head deadline, not held open for ever
