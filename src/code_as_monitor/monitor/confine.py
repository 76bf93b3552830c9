"""Kernel confinement of the sandbox worker: namespaces, ``no_new_privs`` and a seccomp-bpf filter.

:func:`confine` runs inside the worker after it has imported everything it needs and before any monitor
program is loaded. In order:

1. new user and network namespaces (``unshare(CLONE_NEWUSER | CLONE_NEWNET)``) where the kernel allows
   them: the worker holds no capability in the host's namespaces and has no network interface but a
   downed loopback (the socket to the control process is inherited and keeps working);
2. the parent-death signal (the worker dies with the control process) and ``PR_SET_DUMPABLE=0``;
3. ``PR_SET_NO_NEW_PRIVS``: nothing the worker does can gain privileges;
4. a seccomp-bpf filter built with libseccomp (through ``pyseccomp``), an allow-list: reading the
   request socket, writing it and the captured stderr, memory management without ``PROT_EXEC``, futexes,
   signal-mask bookkeeping, clocks, ``abort()`` on itself and exit. Process creation, exec, ptrace,
   other processes' memory, signals to other processes, sockets, namespace changes and the other
   well-known escalation routes kill the worker (``SIGSYS``); every other system call, opening files
   included, fails with ``EPERM``.

Only this function (trusted code) runs between the imports and the filter; nothing here is reachable
from a monitor program.
"""

from __future__ import annotations

import ctypes
import os
import signal
import types
from dataclasses import dataclass, field

CLONE_NEWUSER = 0x10000000
CLONE_NEWNET = 0x40000000
PR_SET_PDEATHSIG = 1
PR_SET_DUMPABLE = 4
PR_SET_NO_NEW_PRIVS = 38
PROT_EXEC = 0x4

ALLOWED: tuple[str, ...] = (
    # memory (mmap/mprotect only without PROT_EXEC, see below)
    "brk", "munmap", "mremap", "madvise",
    # threads and signals of the worker itself
    "futex", "sched_yield", "rt_sigaction", "rt_sigprocmask", "rt_sigreturn", "sigaltstack", "getpid",
    "gettid",
    # clocks
    "clock_gettime", "clock_getres", "gettimeofday", "clock_nanosleep", "nanosleep",
    # the end
    "exit", "exit_group", "close",
)
"""System calls allowed without conditions."""

KILLED: tuple[str, ...] = (
    "execve", "execveat", "fork", "vfork", "clone", "clone3", "ptrace", "process_vm_readv",
    "process_vm_writev", "kill", "tkill", "rt_sigqueueinfo", "rt_tgsigqueueinfo", "pidfd_open",
    "pidfd_send_signal", "pidfd_getfd", "socket", "socketpair", "connect", "bind", "listen", "accept",
    "accept4", "unshare", "setns", "mount", "umount2", "pivot_root", "chroot", "bpf", "perf_event_open",
    "keyctl", "add_key", "request_key", "init_module", "finit_module", "delete_module", "kexec_load",
    "kexec_file_load", "reboot", "userfaultfd", "io_uring_setup", "io_uring_enter", "io_uring_register",
    "seccomp", "prctl", "setuid", "setgid", "setreuid", "setregid", "setresuid", "setresgid", "setgroups",
    "capset", "personality", "open_by_handle_at", "name_to_handle_at", "memfd_create",
    "pkey_mprotect", "ioperm", "iopl", "modify_ldt", "move_pages", "migrate_pages", "mbind",
    "set_mempolicy", "quotactl", "swapon", "swapoff", "acct", "syslog", "lookup_dcookie",
)
"""System calls that kill the worker at once: no monitor program has a reason to make them."""


class ConfinementError(OSError):
    """The seccomp filter (or ``no_new_privs``) could not be installed; the message says why."""


@dataclass
class Confinement:
    """What :func:`confine` installed.

    Attributes:
        seccomp: the seccomp-bpf filter is loaded.
        no_new_privs: ``PR_SET_NO_NEW_PRIVS`` is set.
        user_ns: the worker runs in a new user namespace.
        net_ns: the worker runs in a new network namespace.
        notes: why a namespace (or the whole confinement) is missing.
    """

    seccomp: bool = False
    no_new_privs: bool = False
    user_ns: bool = False
    net_ns: bool = False
    notes: list[str] = field(default_factory=list)

    @property
    def confined(self) -> bool:
        """The kernel enforces the filter (namespaces are extra, where the kernel allows them)."""
        return self.seccomp and self.no_new_privs

    def describe(self) -> str:
        parts = [name for name, on in (("seccomp", self.seccomp), ("no_new_privs", self.no_new_privs),
                                       ("user namespace", self.user_ns), ("network namespace", self.net_ns))
                 if on]
        text = ", ".join(parts) if parts else "nothing"
        return text + (f" ({'; '.join(self.notes)})" if self.notes else "")


def _libc() -> ctypes.CDLL:
    return ctypes.CDLL(None, use_errno=True)


def _unshare(libc: ctypes.CDLL, flags: int) -> int:
    """0 or the errno of ``unshare(flags)``."""
    return 0 if libc.unshare(ctypes.c_int(flags)) == 0 else ctypes.get_errno()


def _namespaces(libc: ctypes.CDLL, info: Confinement) -> None:
    err = _unshare(libc, CLONE_NEWUSER | CLONE_NEWNET)
    if err == 0:
        info.user_ns = info.net_ns = True
        return
    for flag, attr, name in ((CLONE_NEWUSER, "user_ns", "user"), (CLONE_NEWNET, "net_ns", "network")):
        e = _unshare(libc, flag)
        if e == 0:
            setattr(info, attr, True)
        else:
            info.notes.append(f"no new {name} namespace: {os.strerror(e)}")


def load_seccomp() -> types.ModuleType | str:
    """Import ``pyseccomp`` (it locates and loads the system's libseccomp); the module, or why not."""
    try:
        import pyseccomp
    except (ImportError, RuntimeError, OSError) as exc:
        return f"cannot load pyseccomp over the system's libseccomp: {exc}"
    return pyseccomp


def build_filter(sc: types.ModuleType, sock_fd: int, stderr_fd: int, pid: int):
    """The seccomp filter (a ``pyseccomp.SyscallFilter``, not loaded) for a worker with these fds."""
    f = sc.SyscallFilter(sc.ERRNO(1))  # EPERM for everything not named below
    native = sc.system_arch()

    def rule(action: int, name: str, *args) -> None:
        if sc.resolve_syscall(native, name) < 0:
            return  # not a system call on this architecture
        f.add_rule(action, name, *args)

    for name in ALLOWED:
        rule(sc.ALLOW, name)
    for name in KILLED:
        rule(sc.KILL_PROCESS, name)
    rule(sc.ALLOW, "read", sc.Arg(0, sc.EQ, sock_fd))
    rule(sc.ALLOW, "write", sc.Arg(0, sc.EQ, sock_fd))
    rule(sc.ALLOW, "write", sc.Arg(0, sc.EQ, stderr_fd))
    rule(sc.ALLOW, "mmap", sc.Arg(2, sc.MASKED_EQ, PROT_EXEC, 0))
    rule(sc.ALLOW, "mprotect", sc.Arg(2, sc.MASKED_EQ, PROT_EXEC, 0))
    rule(sc.ALLOW, "tgkill", sc.Arg(0, sc.EQ, pid))  # abort() on itself
    rule(sc.KILL_PROCESS, "tgkill", sc.Arg(0, sc.NE, pid))
    return f


def confine(sock_fd: int, stderr_fd: int = 2, namespaces: bool = True,
            seccomp: types.ModuleType | str | None = None) -> Confinement:
    """Confine the calling process for good (see the module docstring).

    Args:
        sock_fd: the one socket the worker may read and write.
        stderr_fd: the captured stderr it may write.
        namespaces: try new user and network namespaces first.
        seccomp: what :func:`load_seccomp` returned (called here when None).
    Returns:
        What was installed; ``confined`` is False (and ``notes`` say why) when the seccomp filter or
        ``no_new_privs`` could not be installed. The caller decides whether to go on.
    """
    info = Confinement()
    try:
        libc = _libc()
    except OSError as exc:
        info.notes.append(f"cannot load the C library: {exc}")
        return info
    parent = os.getppid()
    if namespaces:
        _namespaces(libc, info)
    libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    if os.getppid() != parent:  # the control process died before the death signal was armed
        os._exit(0)
    libc.prctl(PR_SET_DUMPABLE, 0, 0, 0, 0)
    if libc.prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0:
        info.notes.append(f"PR_SET_NO_NEW_PRIVS failed: {os.strerror(ctypes.get_errno())}")
        return info
    info.no_new_privs = True
    sc = load_seccomp() if seccomp is None else seccomp
    if isinstance(sc, str):
        info.notes.append(sc)
        return info
    try:
        flt = build_filter(sc, sock_fd, stderr_fd, os.getpid())
    except (RuntimeError, OSError, ValueError) as exc:
        info.notes.append(f"cannot build the seccomp filter: {exc}")
        return info
    try:
        flt.load()
    except OSError as exc:
        info.notes.append(f"the kernel refused the seccomp filter: {exc.strerror or exc}")
        return info
    info.seccomp = True
    return info
