"""The browser views listen where they say: the live view (viser) and the replay scene's page
(Meshcat) on 127.0.0.1 unless ``--host`` is given, Meshcat's zmq socket (which draws the scene)
on 127.0.0.1 always. Checked on the server process's
own listening sockets (Linux: /proc/<pid>/fd and /proc/net/tcp{,6}), not on the URL it prints:
meshcat 0.3.2's server printed http://127.0.0.1:7000 while listening on 0.0.0.0 and ::."""

from __future__ import annotations

import os
import socket
import urllib.request
from pathlib import Path
from urllib.parse import urlsplit

import pytest

import wbc
from wbc.cli.main import build_parser, main
from wbc.viz import Scene

pytestmark = pytest.mark.skipif(not Path("/proc/net/tcp").exists(), reason="reads Linux's /proc/net/tcp")


def _address(hex_ip: str) -> str:
    raw = bytes.fromhex(hex_ip)
    if len(raw) == 4:
        return socket.inet_ntop(socket.AF_INET, raw[::-1])
    return socket.inet_ntop(socket.AF_INET6, b"".join(raw[i:i + 4][::-1] for i in range(0, 16, 4)))


def listening(pid: int) -> set[tuple[str, int]]:
    """(address, port) of every TCP socket process ``pid`` listens on."""
    inodes = set()
    for fd in Path(f"/proc/{pid}/fd").iterdir():
        try:
            target = os.readlink(fd)
        except FileNotFoundError:       # closed meanwhile (another thread's)
            continue
        if target.startswith("socket:["):
            inodes.add(target[8:-1])
    out = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        for line in Path(table).read_text().splitlines()[1:]:
            cols = line.split()
            ip, port = cols[1].split(":")
            if cols[3] == "0A" and cols[9] in inodes:         # 0A: TCP_LISTEN
                out.add((_address(ip), int(port, 16)))
    return out


@pytest.fixture(scope="module")
def panda():
    return wbc.load_robot("panda")


@pytest.mark.parametrize("host", [None, "127.0.0.2", "0.0.0.0"])
def test_page_listens_on_its_host_and_the_scene_socket_on_loopback(panda, host):
    scene = Scene(panda, []) if host is None else Scene(panda, [], host=host)
    try:
        url = urlsplit(scene.url)
        zmq = urlsplit(scene.vis.window.zmq_url)
        expected = host or "127.0.0.1"
        assert url.hostname == expected and zmq.hostname == "127.0.0.1"
        assert listening(scene.server.pid) == {(expected, url.port), ("127.0.0.1", zmq.port)}
        page = f"http://{'127.0.0.1' if expected == '0.0.0.0' else expected}:{url.port}/static/"
        with urllib.request.urlopen(page, timeout=10) as r:       # and the page is served there
            assert r.status == 200 and b"meshcat" in r.read().lower()
    finally:
        scene.close()
    assert scene.server.poll() is not None                     # close stopped it


def test_cli_host_option(capsys):
    assert build_parser().parse_args(["run", "x"]).host == "127.0.0.1"
    assert main(["run", "tiago_reach", "--duration", "0.002", "--host", "127.0.0.2"]) == 0
    out = capsys.readouterr()
    assert "wbc: browser view at http://127.0.0.2:" in out.out, out
    # an address this machine does not have (TEST-NET-3): a clear error, exit 2
    assert main(["run", "tiago_reach", "--duration", "0.002", "--host", "203.0.113.7"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: the live view could not listen on '203.0.113.7'") and "Traceback" not in err


@pytest.mark.parametrize("host", [None, "127.0.0.2"])
def test_live_view_listens_on_its_host_only(panda, host):
    pytest.importorskip("viser", reason="the live view needs viser")
    from wbc.viz.live import LiveView

    view = LiveView(panda, []) if host is None else LiveView(panda, [], host=host)
    try:
        port = urlsplit(view.url).port
        expected = host or "127.0.0.1"
        assert urlsplit(view.url).hostname == expected
        assert not {a for a in listening(os.getpid()) if a[1] == port}    # the drawing process serves, not this one
        mine = {a for a in listening(view.pid) if a[1] == port}
        assert mine == {(expected, port)}, mine
        with urllib.request.urlopen(f"http://{expected}:{port}/", timeout=10) as r:   # the page is served
            assert r.status == 200
    finally:
        view.close()
