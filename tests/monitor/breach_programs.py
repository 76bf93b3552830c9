"""Programs for a worker whose allow-list and namespace have failed (``breached_worker.py``): they hold the
real builtins and ``os``, ``sys``, ``socket``, ``threading``, ``subprocess``, ``signal``, ``ctypes``,
``mmap`` and ``resource``, and do what an attacker would do next. Constraints ``a`` (during) and ``b``
(upon); every program defines a well-behaved ``check_b``.

Each entry is ``(name, source, kind, needle, ends)``:
    fault   check_a is a fault whose reason matches the regex ``needle`` (the kernel said no: ``EPERM``,
            ``ENOMEM``, ``EFBIG``); check_b is unaffected and the worker lives on;
    frame   every check of the frame is a fault whose reason matches ``needle`` (the worker was killed
            by the filter, died, or overran the deadline and was killed);
    either  check_a is a fault matching ``needle``, alone or with the whole frame;
    clean   check_a returns a verdict (no fault) that the host has sanitised; ``needle`` is in its reason.
``ends``: for ``frame``, the worker's exit status the test then waits for (``-SIGSYS``: the seccomp filter
killed it); None when any end will do.
"""

from __future__ import annotations

import signal

from hostile_attacks import CANARY

SECRET_ENV = "CAM_BREACH_TEST_SECRET"
"""An environment variable of the control process that no program may read."""

GOOD_B = '''

def check_b(E, H, t):
    return True, "fine", 1.0
'''

IMPORTS = ("os = __import__('os')\nsys = __import__('sys')\nsignal = __import__('signal')\n"
           "ctypes = __import__('ctypes')\nlibc = ctypes.CDLL(None, use_errno=True)\n")


def _a(body: str) -> str:
    lines = "\n".join("    " + line for line in (IMPORTS + body.strip("\n")).splitlines())
    return f"def check_a(E, H, t):\n{lines}\n" + GOOD_B


SYS = -signal.SIGSYS
DENIED = "PermissionError"

BREACHES: list[tuple[str, str, str, str, int | None]] = [
    # --- files: every open fails (EPERM), reading, writing and listing alike ---------------------------
    ("read_file", _a("return True, open('/etc/hostname').read()"), "fault", DENIED, None),
    ("read_passwd_raw", _a("fd = os.open('/etc/passwd', os.O_RDONLY)\nreturn True, str(os.read(fd, 200))"),
     "fault", DENIED, None),
    ("read_own_environ", _a("return True, open('/proc/self/environ', 'rb').read().decode()"), "fault", DENIED,
     None),
    ("read_parent_memory_file", _a("f = open(f'/proc/{os.getppid()}/mem', 'rb')\nreturn True, 'x'"), "fault",
     DENIED, None),
    ("write_canary", _a(f"open({CANARY!r}, 'w').write('escaped')\nreturn True, 'x'"), "fault", DENIED, None),
    ("create_canary_raw", _a(f"os.open({CANARY!r}, os.O_CREAT | os.O_WRONLY, 0o644)\nreturn True, 'x'"), "fault",
     DENIED, None),
    ("list_root", _a("return True, str(os.listdir('/'))"), "fault", DENIED, None),
    ("list_own_fds", _a("return True, str(os.listdir('/proc/self/fd'))"), "fault", DENIED, None),
    ("stat_shadow", _a("return True, str(os.stat('/etc/shadow'))"), "fault", DENIED, None),
    ("chdir_root", _a("os.chdir('/')\nreturn True, 'x'"), "fault", DENIED, None),
    ("import_new_module", _a("m = __import__('sqlite3')\nreturn True, 'x'"), "fault", "Error", None),
    ("exec_then_syscall", _a("ns = {}\nexec('import os\\nx = os.getcwd()', ns)\nreturn True, ns['x']"), "fault",
     DENIED, None),
    # --- inherited file descriptors --------------------------------------------------------------------
    ("write_stdout", _a("os.write(1, b'leak')\nreturn True, 'x'"), "fault", DENIED, None),
    ("write_stdin", _a("os.write(0, b'leak')\nreturn True, 'x'"), "fault", DENIED, None),
    ("stderr_flood", _a("for i in range(200):\n    os.write(2, b'E' * 65536)\nreturn True, 'x'"), "fault",
     "OSError", None),
    ("truncate_stderr", _a("os.ftruncate(2, 0)\nreturn True, 'x'"), "fault", DENIED, None),
    ("dup_over_socket", _a("os.dup2(2, int(sys.argv[2]))\nreturn True, 'x'"), "fault", DENIED, None),
    ("socket_object_from_fd", _a("s = __import__('socket').socket(fileno=int(sys.argv[2]))\nreturn True, 'x'"),
     "either", "raised|died", None),
    ("close_own_socket", _a("os.close(int(sys.argv[2]))\nreturn True, 'x'"), "frame", "died", None),
    # --- processes: creation and exec kill the worker ---------------------------------------------------
    ("os_system", _a(f"os.system('touch {CANARY}')\nreturn True, 'x'"), "frame", "died", SYS),
    ("exec_shell", _a(f"os.execv('/bin/sh', ['sh', '-c', 'touch {CANARY}'])"), "frame", "died", SYS),
    ("fork", _a("pid = os.fork()\nreturn True, str(pid)"), "frame", "died", SYS),
    ("posix_spawn", _a("os.posix_spawn('/bin/true', ['true'], {})\nreturn True, 'x'"), "frame", "died", SYS),
    ("subprocess_popen", _a(f"__import__('subprocess').Popen(['/bin/sh', '-c', 'touch {CANARY}'])\n"
                            "return True, 'x'"), "either", "PermissionError|died", None),
    ("libc_system", _a(f"libc.system(b'touch {CANARY}')\nreturn True, 'x'"), "frame", "died", SYS),
    ("libc_vfork", _a("libc.vfork()\nreturn True, 'x'"), "frame", "died", SYS),
    ("thread_start", _a("th = __import__('threading').Thread(target=len, args=((),))\nth.start()\n"
                        "return True, 'x'"), "frame", "died", SYS),
    # --- other processes: signals, tracing, memory ----------------------------------------------------
    ("kill_parent", _a("os.kill(os.getppid(), signal.SIGKILL)\nreturn True, 'x'"), "frame", "died", SYS),
    ("probe_parent", _a("os.kill(os.getppid(), 0)\nreturn True, 'x'"), "frame", "died", SYS),
    ("signal_own_group", _a("os.killpg(0, 0)\nreturn True, 'x'"), "frame", "died", SYS),
    ("tgkill_parent", _a("p = os.getppid()\nlibc.tgkill(p, p, 0)\nreturn True, 'x'"), "frame", "died", SYS),
    ("ptrace_parent", _a("libc.ptrace(16, os.getppid(), 0, 0)\nreturn True, 'x'"), "frame", "died", SYS),
    ("write_parent_memory", _a("libc.process_vm_writev(os.getppid(), 0, 0, 0, 0, 0)\nreturn True, 'x'"),
     "frame", "died", SYS),
    ("pidfd_parent", _a("os.pidfd_open(os.getppid())\nreturn True, 'x'"), "frame", "died", SYS),
    # --- network, namespaces, privileges ----------------------------------------------------------------
    ("inet_socket", _a("s = __import__('socket').socket()\ns.connect(('127.0.0.1', 22))\nreturn True, 'x'"),
     "frame", "died", SYS),
    ("unix_socket", _a("s = __import__('socket').socket(1, 1)\nreturn True, 'x'"), "frame", "died", SYS),
    ("new_socketpair", _a("a, b = __import__('socket').socketpair()\nreturn True, 'x'"), "frame", "died", SYS),
    ("unshare_mounts", _a("libc.unshare(0x00020000)\nreturn True, 'x'"), "frame", "died", SYS),
    ("setuid_root", _a("os.setuid(0)\nreturn True, 'x'"), "frame", "died", SYS),
    ("prctl_dumpable", _a("libc.prctl(4, 1, 0, 0, 0)\nreturn True, 'x'"), "frame", "died", SYS),
    ("memfd", _a("os.memfd_create('payload')\nreturn True, 'x'"), "frame", "died", SYS),
    ("setsid", _a("os.setsid()\nreturn True, 'x'"), "fault", DENIED, None),
    ("nice_up", _a("os.nice(-5)\nreturn True, 'x'"), "fault", DENIED, None),
    # --- memory and limits ------------------------------------------------------------------------------
    ("executable_mapping", _a("m = __import__('mmap').mmap(-1, 4096, prot=7)\nreturn True, 'x'"), "fault", DENIED,
     None),
    ("huge_mapping", _a("m = __import__('mmap').mmap(-1, 10 ** 11)\nreturn True, 'x'"), "fault",
     "OSError|MemoryError", None),
    ("raise_memory_limit", _a("r = __import__('resource')\nr.setrlimit(r.RLIMIT_AS, (-1, -1))\nreturn True, 'x'"),
     "fault", "raised", None),
    ("alarm_timer", _a("signal.setitimer(signal.ITIMER_REAL, 0.001)\nreturn True, 'x'"), "fault", "raised", None),
    ("segfault", _a("ctypes.string_at(0)\nreturn True, 'x'"), "frame", "died", -signal.SIGSEGV),
    ("c_stack_overflow", "def f(n):\n    return f(n + 1)\n\n" + _a("sys.setrecursionlimit(10 ** 7)\nf(0)\n"
                                                                "return True, 'x'"), "frame", "died|deadline",
     None),
    # --- its own end, and hanging the host ----------------------------------------------------------------
    ("system_exit", _a("raise SystemExit(0)"), "fault", "SystemExit", None),
    ("keyboard_interrupt", _a("raise KeyboardInterrupt"), "fault", "KeyboardInterrupt", None),
    ("hard_exit", _a("os._exit(0)"), "frame", "died", 0),
    ("abort", _a("os.abort()"), "frame", "died", -signal.SIGABRT),
    ("kill_itself", _a("signal.pthread_kill(__import__('threading').get_ident(), signal.SIGKILL)\n"
                       "return True, 'x'"), "frame", "died", -signal.SIGKILL),
    ("sleep_past_deadline", _a("__import__('time').sleep(30)\nreturn True, 'x'"), "frame", "deadline", None),
    ("stop_itself", _a("signal.raise_signal(signal.SIGSTOP)\nreturn True, 'x'"), "frame", "deadline", None),
    ("block_signals_and_spin", _a("signal.pthread_sigmask(signal.SIG_BLOCK, range(1, 65))\n"
                                  "for i in range(10 ** 12):\n    pass\nreturn True, 'x'"), "frame", "deadline",
     None),
    # --- what comes back ----------------------------------------------------------------------------------
    ("environment_secret", _a(f"return True, 'secret=' + repr(os.environ.get({SECRET_ENV!r}))"), "clean",
     "secret=None", None),
    ("raw_write_into_inputs", _a("ctypes.memmove(E[0].ctypes.data, b'\\x00' * 24, 24)\n"
                                 "ctypes.memmove(H.t.ctypes.data, b'\\x00' * 8, 8)\nreturn True, 'wrote'"), "clean",
     "wrote", None),
    ("reason_30_million", _a("return True, 'A' * 30_000_000"), "clean", "AAA", None),
    ("poison_worker_builtins", _a("__import__('builtins').len = abs\nreturn True, 'x'"), "frame", "died", 1),
    ("reason_object_address", _a("return True, repr(object()) + repr(libc)"), "clean", "0x?", None),
]
"""After a full escape from layers 1-2: the kernel and the host stop or contain every one."""

DEFAULT = {"read_file", "write_canary", "list_own_fds", "stderr_flood", "os_system", "thread_start", "kill_parent",
           "inet_socket", "stop_itself", "environment_secret", "raw_write_into_inputs", "reason_30_million"}
"""The cases kept in the default suite (one or two per class); the others are ``slow``."""
