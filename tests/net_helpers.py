"""Network helpers shared by the viewer tests."""

import socket
import sys

#: ``fuzzynav ...`` as a child that Ctrl-C (SIGINT) interrupts, whoever started the
#: tests: a shell starts a background job (``make test &``) with SIGINT ignored, every
#: child inherits that, and Python then installs no handler of its own, so the signal a
#: test sends would go unheard (a clean clone's suite run in the background hung 30 s in
#: two tests). The command line itself keeps the shell's choice, as a background job
#: should.
INTERRUPTIBLE_CLI = [
    sys.executable,
    "-c",
    "import signal, sys\n"
    "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
    "from fuzzynav.app.cli import main\n"
    "sys.exit(main(sys.argv[1:]))\n",
]


def port_is_free(port: int) -> bool:
    """Whether a server could listen on the port now (as servers do, with SO_REUSEADDR:
    connections a closed server leaves in TIME_WAIT do not hold the port)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind(("127.0.0.1", port))
            s.listen()
        except OSError:
            return False
    return True
