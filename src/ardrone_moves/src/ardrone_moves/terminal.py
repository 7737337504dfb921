"""Single keys from a terminal, or lines from a pipe, without blocking; ROS-free.

On a TTY the terminal is switched to non-canonical, no-echo mode (cbreak) so every key arrives
at once, and restored on exit. Ctrl-C still raises SIGINT (ISIG stays on) and output keeps its
newline translation, so log lines stay readable. If stdin is not a TTY, bytes are read as they
come (scripts and tests pipe keys, one line at a time).
"""
import codecs
import os
import select
import termios
import time


class TerminalKeys:
    def __init__(self, stream):
        self.fd = stream.fileno()
        self.is_tty = os.isatty(self.fd)
        self.closed = False  # end of input: nothing more will come
        self._saved = None
        self._decoder = codecs.getincrementaldecoder("utf-8")(errors="replace")

    def __enter__(self):
        if self.is_tty:
            self._saved = termios.tcgetattr(self.fd)
            mode = termios.tcgetattr(self.fd)
            mode[3] &= ~(termios.ICANON | termios.ECHO)  # lflags
            mode[6][termios.VMIN], mode[6][termios.VTIME] = 1, 0
            termios.tcsetattr(self.fd, termios.TCSANOW, mode)  # TCSANOW keeps keys typed ahead
        return self

    def __exit__(self, *exc):
        self.restore()
        return False

    def restore(self):
        if self._saved is not None:
            termios.tcsetattr(self.fd, termios.TCSADRAIN, self._saved)
            self._saved = None

    def read(self, timeout):
        """The keys that arrive within ``timeout`` s ('' if none); sets ``closed`` at end of input."""
        if self.closed:
            time.sleep(max(0.0, timeout))  # keep the caller's pace: it still ticks without keys
            return ""
        ready, _, _ = select.select([self.fd], [], [], max(0.0, timeout))
        if not ready:
            return ""
        try:
            data = os.read(self.fd, 1024)
        except OSError:  # terminal hung up
            data = b""
        if not data:
            self.closed = True
            return self._decoder.decode(b"", final=True)
        return self._decoder.decode(data)
