"""A dashboard client for the tests: one connection, one reply line per command (how URCL's dashboard client reads)."""
import socket


class LineClient:
    """One dashboard connection on `host`:29999; `ask(command)` sends a line and returns the reply line."""

    def __init__(self, host, timeout=10):
        self.sock = socket.create_connection((host, 29999), timeout=timeout)
        self.reader = self.sock.makefile("r", encoding="utf-8")
        self.reader.readline()

    def ask(self, command):
        self.sock.sendall(command.encode() + b"\n")
        return self.reader.readline().rstrip("\n")

    def close(self):
        self.sock.close()
