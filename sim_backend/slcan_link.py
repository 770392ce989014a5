"""A CAN link to `dyno sim-rig` over TCP on 127.0.0.1, speaking slcan (rig/slcan.py): the
controller opens it with python-can's slcan interface and channel
"socket://127.0.0.1:PORT", as it would a USB-CAN adapter. To the CAN nodes it looks like
a python-can bus (send, recv)."""
from __future__ import annotations

import collections
import socket
import threading

import can

from rig import slcan
from rig.errors import RigError


class SlcanLink:
    def __init__(self, port):
        self.server = socket.create_server(("127.0.0.1", port))
        self.port = self.server.getsockname()[1]
        self.conn = None
        self.rx = collections.deque()
        self.lock = threading.Lock()
        self.bad_lines = 0
        self.running = True
        self.thread = threading.Thread(target=self._serve, name="slcan", daemon=True)
        self.thread.start()

    def _serve(self):
        while self.running:
            try:
                conn, _ = self.server.accept()
            except OSError:
                return
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            with self.lock:
                self.conn = conn
            buf = b""
            while self.running:
                try:
                    chunk = conn.recv(4096)
                except OSError:
                    break
                if not chunk:
                    break
                buf += chunk
                *lines, buf = buf.split(b"\r")
                for line in lines:
                    self._handle(conn, line.strip(b"\n"))
            with self.lock:
                self.conn = None
            conn.close()

    def _handle(self, conn, line):
        if not line:
            return
        try:
            kind, *rest = slcan.parse_line(line)
        except RigError:
            self.bad_lines += 1
            self._write(slcan.ERROR)
            return
        if kind == "frame":
            ident, extended, data = rest
            self.rx.append(can.Message(arbitration_id=ident, is_extended_id=extended, data=data))
        else:
            self._write(b"V1013\r" if rest[0] == "V" else slcan.OK)

    def _write(self, data):
        with self.lock:
            conn = self.conn
        if conn is not None:
            try:
                conn.sendall(data)
            except OSError:
                pass

    # the python-can bus surface the CAN nodes use
    def send(self, msg):
        self._write(slcan.format_frame(msg.arbitration_id, bytes(msg.data), msg.is_extended_id))

    def recv(self, timeout=0.0):
        try:
            return self.rx.popleft()
        except IndexError:
            return None

    def shutdown(self):
        self.running = False
        self.server.close()
        with self.lock:
            if self.conn is not None:
                self.conn.close()
