"""The kernel layer on its own: a process confined exactly as a worker confines itself, then running
*trusted* attack code (as if every layer above had failed), cannot open files, run or create processes,
signal or trace others, open sockets, map executable memory, or change its namespaces.

Each attack runs in a child forked from the test process; the child confines itself, reports on its
socket (the one file it may write) and exits, or is killed by the filter (SIGSYS).
"""

from __future__ import annotations

import ctypes
import mmap
import os
import signal
import socket
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest
from hostile_attacks import CANARY

from code_as_monitor.monitor.confine import confine

LIBC = ctypes.CDLL(None, use_errno=True)
KILLED = "killed by SIGSYS"


def run_confined(attack, timeout: float = 20.0) -> tuple[str, str]:
    """Fork, confine the child like a worker, run ``attack()`` there: (how the child ended, what it said)."""
    ours, theirs = socket.socketpair()
    pid = os.fork()
    if pid == 0:  # the child: never returns into pytest
        try:
            ours.close()
            fd = theirs.fileno()
            info = confine(fd, 2)
            os.write(fd, f"confined={info.confined};".encode())
            try:
                said = f"returned {attack()!r}"
            except BaseException as exc:
                said = f"raised {type(exc).__name__}"
            os.write(fd, said.encode()[:500])
        finally:
            os._exit(0)
    theirs.close()
    end = time.monotonic() + timeout
    while True:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            break
        if time.monotonic() > end:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            raise AssertionError("confined child did not finish")
        time.sleep(0.005)
    ours.settimeout(1.0)
    chunks = []
    while (chunk := ours.recv(4096)):
        chunks.append(chunk)
    ours.close()
    if os.WIFSIGNALED(status):
        how = f"killed by {signal.Signals(os.WTERMSIG(status)).name}"
    else:
        how = f"exit {os.WEXITSTATUS(status)}"
    return how, b"".join(chunks).decode()


def _ptrace_traceme() -> int:
    return LIBC.ptrace(0, 0, 0, 0)


def _read_file() -> str:
    with open("/etc/hostname") as f:
        return f.read()


def _write_canary() -> None:
    with open(CANARY, "w") as f:
        f.write("escaped")


def _mprotect_exec() -> int:
    buf = mmap.mmap(-1, 4096)
    addr = ctypes.addressof(ctypes.c_char.from_buffer(buf))
    return LIBC.mprotect(ctypes.c_void_p(addr), 4096, 7)


ATTACKS = [
    ("read_file", _read_file, "raised PermissionError"),
    ("write_canary", _write_canary, "raised PermissionError"),
    ("list_directory", lambda: os.listdir("/"), "raised PermissionError"),
    ("stat_file", lambda: os.stat("/etc/passwd"), "raised PermissionError"),
    ("write_stdout", lambda: os.write(1, b"leak"), "raised PermissionError"),
    ("exec_program", lambda: os.execv("/bin/true", ["true"]), KILLED),
    ("fork", os.fork, KILLED),
    ("spawn_subprocess", lambda: subprocess.run(["/bin/true"], check=False), "raised PermissionError|" + KILLED),
    ("inet_socket", lambda: socket.socket(socket.AF_INET, socket.SOCK_STREAM), KILLED),
    ("unix_socket", lambda: socket.socket(socket.AF_UNIX, socket.SOCK_STREAM), KILLED),
    ("signal_parent", lambda: os.kill(os.getppid(), 0), KILLED),
    ("signal_init", lambda: os.kill(1, 0), KILLED),
    ("signal_group", lambda: os.killpg(0, 0), KILLED),
    ("ptrace", _ptrace_traceme, KILLED),
    ("read_parent_memory", lambda: LIBC.process_vm_readv(os.getppid(), None, 0, None, 0, 0), KILLED),
    ("executable_mapping", lambda: mmap.mmap(-1, 4096, prot=mmap.PROT_READ | mmap.PROT_EXEC), "raised PermissionError"),
    ("make_memory_executable", _mprotect_exec, "returned -1"),
    ("x32_abi_getpid", lambda: LIBC.syscall(0x40000000 | 39), KILLED + "|returned -1"),
    ("prctl", lambda: LIBC.prctl(3, 0, 0, 0, 0), KILLED),
    ("new_namespace", lambda: LIBC.unshare(0x40000000), KILLED),
    ("setuid", lambda: os.setuid(0), KILLED),
    ("memfd", lambda: os.memfd_create("x"), KILLED),
    ("bpf", lambda: LIBC.syscall(321, 0, 0, 0), KILLED),
    ("io_uring", lambda: LIBC.syscall(425, 1, 0), KILLED),
    ("perf_event_open", lambda: LIBC.syscall(298, 0, 0, -1, -1, 0), KILLED),
    ("abort_itself", os.abort, "killed by SIGABRT"),  # signals to itself are allowed
    ("compute", lambda: float(np.linalg.norm(np.ones((64, 64)) @ np.ones((64, 64)))), "returned 4096.0"),
]


@pytest.mark.parametrize(("name", "attack", "expected"), ATTACKS, ids=[a[0] for a in ATTACKS])
def test_confined_process_is_stopped_by_the_kernel(name, attack, expected):
    how, said = run_confined(attack)
    assert said.startswith("confined=True;"), (how, said)
    outcome = f"{how} {said}"
    assert any(e in outcome for e in expected.split("|")), outcome
    assert not os.path.exists(CANARY)


def test_without_seccomp_the_sandbox_refuses_unless_opted_out(tmp_path):
    """A parent that forbids seccomp filters (as some containers do): the worker cannot confine itself,
    the sandbox says why and runs nothing, unless told explicitly that unconfined is acceptable."""
    script = textwrap.dedent(f"""
        import sys
        sys.path.insert(0, {os.path.dirname(__file__)!r})
        import numpy as np
        import pyseccomp as sc
        from code_as_monitor.core.errors import SandboxError
        from code_as_monitor.monitor.runtime import MonitorRuntime
        from code_as_monitor.monitor.sandbox import Sandbox
        from hostile_programs import GOOD
        from code_as_monitor.core.constraints import Constraint
        f = sc.SyscallFilter(sc.ALLOW)
        f.add_rule(sc.ERRNO(1), "seccomp")
        f.add_rule(sc.ERRNO(1), "prctl", sc.Arg(0, sc.EQ, 22))
        f.load()
        cs = [Constraint("a", "x", "during"), Constraint("b", "y", "upon")]
        E = {{0: np.array([[0.0, 0.0, 0.22]]), 1: np.array([[0.0, 0.0, 0.2]] * 4)}}
        try:
            MonitorRuntime().sandbox.start()
            print("STARTED")
        except SandboxError as exc:
            print("REFUSED", exc)
        with Sandbox(allow_unconfined=True, deadline_s=5.0) as sb:  # a generous deadline: a loaded machine
            sb.load(GOOD, cs)
            vs = sb.evaluate(E, None, None, 0.0)
            print("OPTED OUT", [v.ok for v in vs], sb.confinement, [v.reason for v in vs if v.fault])
    """)
    env = {k: v for k, v in os.environ.items() if k != "CAM_ALLOW_UNCONFINED"}
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120, env=env,
                         cwd=tmp_path)
    assert out.returncode == 0, out.stderr[-2000:]
    lines = out.stdout.splitlines()
    refused = next(line for line in lines if line.startswith(("REFUSED", "STARTED")))
    assert refused.startswith("REFUSED") and "could not be confined" in refused
    assert "seccomp filter" in refused and "allow_unconfined=True" in refused
    assert "CAM_ALLOW_UNCONFINED=1" in refused
    opted = next(line for line in lines if line.startswith("OPTED OUT"))
    assert "[True, True]" in opted and "seccomp filter" in opted and "no_new_privs" in opted
