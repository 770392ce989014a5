"""The virtual rig's CAN bus served to another process as a socketcand daemon on
127.0.0.1 (rig/codecs/socketcand.py): the controller opens it with python-can's socketcand
interface, as it would a real socketcand on a cell's Linux box. To the CAN nodes it looks
like a python-can bus (send, recv)."""
from __future__ import annotations

import collections
import socket
import threading
import time

import can

from rig.codecs import socketcand
from rig.errors import RigError


class SocketcandServer:
    def __init__(self, port):
        self.server = socket.create_server(("127.0.0.1", port))
        self.port = self.server.getsockname()[1]
        self.conn = None
        self.raw = False
        self.raw_from = 0.0
        self.rx = collections.deque()
        self.lock = threading.Lock()
        self.bad_messages = 0
        self.running = True
        self.thread = threading.Thread(target=self._serve, name="socketcand", daemon=True)
        self.thread.start()

    def _serve(self):
        while self.running:
            try:
                conn, _ = self.server.accept()
            except OSError:
                return
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            conn.sendall(b"< hi >")
            with self.lock:
                self.conn, self.raw = conn, False
            buf = ""
            while self.running:
                try:
                    chunk = conn.recv(4096)
                except OSError:
                    break
                if not chunk:
                    break
                messages, buf = socketcand.split_messages(buf + chunk.decode("ascii", "replace"))
                for m in messages:
                    self._handle(conn, m)
            with self.lock:
                self.conn, self.raw = None, False
            conn.close()

    def _handle(self, conn, message):
        try:
            kind, *rest = socketcand.parse(message)
        except RigError:
            self.bad_messages += 1
            self._write("< error bad message >")
            return
        if kind == "send":
            ident, data = rest
            self.rx.append(can.Message(arbitration_id=ident, is_extended_id=ident > 0x7FF, data=data))
        else:
            self._write("< ok >")
            if kind == "rawmode":
                # frames start 50 ms after the "< ok >": python-can's client reads the reply
                # with one recv and refuses "< ok >" with frames behind it in the same read
                self.raw_from = time.monotonic() + 0.05
                self.raw = True

    def _write(self, text):
        with self.lock:
            conn = self.conn
        if conn is not None:
            try:
                conn.sendall(text.encode("ascii"))
            except OSError:
                pass

    # the python-can bus surface the CAN nodes use
    def send(self, msg):
        if self.raw and time.monotonic() >= self.raw_from:
            self._write(socketcand.frame(msg.arbitration_id, bytes(msg.data), time.time()))

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
