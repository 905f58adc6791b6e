"""Recording a simulator's RTDE stream on a plain socket: every data package of one output recipe, in order.

sim_ursim streams every control cycle (a late one too), and the kernel keeps what this reader has not read yet (a
4 MiB receive buffer), so no cycle is lost however loaded the machine; ur_rtde's receiver keeps only the newest
package. Used as a context manager around what the test wants recorded:

>>> with RTDERecorder(host, ["timestamp", "actual_q"]) as recorder:    # doctest: +SKIP
...     play_the_program()
...     ten_seconds_on = recorder.wait_for(lambda row: row[0] > 10.0)
>>> recorder.rows    # one tuple of flat values per cycle      # doctest: +SKIP
"""
import socket
import threading

from sim_ursim.rtde import protocol

RTDE_PORT = 30004


class RTDERecorder:
    """The data packages of the recipe `names` at `frequency` Hz on `host`, as tuples of flat values (`rows`)."""

    def __init__(self, host, names, frequency=500.0, timeout=10.0):
        self.host, self.names, self.frequency, self.timeout = host, list(names), frequency, timeout
        self.rows = []
        self._arrived = threading.Condition()
        self._done = threading.Event()
        self._buffer = bytearray()
        self._stream = None
        self._reader = None
        self.error = None

    def __enter__(self):
        stream = self._stream = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        stream.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 22)
        stream.settimeout(self.timeout)
        stream.connect((self.host, RTDE_PORT))
        assert protocol.parse_accepted_reply(self._reply(protocol.pack_protocol_version_request(2)))
        recipe_id, types = protocol.parse_setup_outputs_reply(
            self._reply(protocol.pack_setup_outputs_request(self.names, self.frequency, 2)), 2)
        assert recipe_id, f"output recipe {self.names} refused: {types}"
        layout = protocol.recipe_struct(types)
        assert protocol.parse_accepted_reply(self._reply(protocol.pack_start_request()))
        self._reader = threading.Thread(target=self._read, args=(layout,), daemon=True)
        self._reader.start()
        return self

    def __exit__(self, *exc):
        self._done.set()
        self._stream.shutdown(socket.SHUT_RDWR)
        self._reader.join(timeout=10)
        self._stream.close()

    def wait_for(self, condition, since=0, timeout=30.0):
        """The index of the first row from `since` on that satisfies `condition(row)`, once recorded;
        AssertionError after `timeout` s."""
        hit = None

        def found():
            nonlocal since, hit
            hit = next((i for i in range(since, len(self.rows)) if condition(self.rows[i])), None)
            since = len(self.rows) if hit is None else hit
            return hit is not None or self.error is not None

        with self._arrived:
            assert self._arrived.wait_for(found, timeout), f"no RTDE row as expected within {timeout} s"
        assert self.error is None, self.error
        return hit

    def _package(self):
        while (found := protocol.split_package(self._buffer)) is None:
            chunk = self._stream.recv(1 << 16)
            if not chunk:
                raise EOFError("the simulator closed the RTDE stream")
            self._buffer.extend(chunk)
        del self._buffer[:found[2]]
        return found[0], found[1]

    def _reply(self, request):
        self._stream.sendall(request)
        while (answer := self._package())[0] != request[2]:
            pass
        return answer[1]

    def _read(self, layout):
        try:
            while not self._done.is_set():
                kind, payload = self._package()
                if kind == protocol.PackageType.DATA_PACKAGE:
                    row = protocol.parse_data_package(payload, layout)[1]
                    with self._arrived:
                        self.rows.append(row)
                        self._arrived.notify_all()
        except (OSError, EOFError) as error:
            if not self._done.is_set():
                self.error = error
                with self._arrived:
                    self._arrived.notify_all()
