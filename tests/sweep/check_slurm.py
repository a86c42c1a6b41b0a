#!/usr/bin/env python3
"""`nvstim sweep --slurm` on a one-node Slurm cluster started here (docs/sweep.md, "Slurm").

Usage: check_slurm.py NVSTIM SOURCE_DIR WORK_DIR

Starts munged, slurmctld and slurmd (Debian's munge and slurm-wlm) in a temporary folder with
a generated slurm.conf (this host as the one node, 2 CPUs; free ports; the munge socket given
through AuthInfo), runs tests/sweep/grid24.toml through them as one job array, and checks that
its results table equals the local one (WORK_DIR/local, written by check_sweep.py local) in
every column but the timing and host columns. Every daemon is stopped at the end, also on a
failure. Where the daemons cannot start (a program missing, munged or slurmd refusing, not
root), it prints "SKIPPED: <why>" with the daemon's log tail and exits 0.
"""
import atexit
import ctypes
import getpass
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time

NVSTIM, SOURCE, WORK = sys.argv[1:4]
SPEC = os.path.join(SOURCE, "tests", "sweep", "grid24.toml")
daemons = []  # (name, Popen, log)
tmp = tempfile.mkdtemp(prefix="nvs-slurm-")  # short: a socket path holds at most 107 bytes
env = dict(os.environ, SLURM_CONF=os.path.join(tmp, "slurm.conf"))


def tail(path, n=8):
    try:
        with open(path, errors="replace") as f:
            return " | ".join(line.rstrip() for line in f.read().splitlines()[-n:])
    except OSError:
        return "(no log)"


def stop_all():
    """scancel what is left, then every daemon: SIGTERM, SIGKILL after 10 s."""
    ctld = [p for name, p, _ in daemons if name == "slurmctld" and p.poll() is None]
    if ctld and shutil.which("scancel"):
        try:
            subprocess.run(["scancel", "--user", getpass.getuser()], env=env,
                           capture_output=True, timeout=10)
        except subprocess.TimeoutExpired:
            pass
    for name, p, _ in reversed(daemons):
        if p.poll() is None:
            p.terminate()
            try:
                p.wait(10)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
    daemons.clear()
    shutil.rmtree(tmp, ignore_errors=True)


atexit.register(stop_all)
for sig in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP):
    signal.signal(sig, lambda s, f: sys.exit(128 + s))


def skip(why, log=None):
    """Skipped, with the daemon's log and its stdout/stderr (LOG.out) where there are."""
    logs = ""
    if log:
        logs = "; log: " + tail(log) + "; output: " + tail(log + ".out")
    print("SKIPPED: " + why + logs)
    sys.exit(0)


def fail(msg):
    print("FAIL: " + msg)
    sys.exit(1)


def free_ports(n):
    socks = [socket.socket() for _ in range(n)]
    for s in socks:
        s.bind(("127.0.0.1", 0))
    ports = [s.getsockname()[1] for s in socks]
    for s in socks:
        s.close()
    return ports


def die_with_parent():
    """In the daemon before exec: SIGTERM when this script dies, even by SIGKILL (prctl
    PR_SET_PDEATHSIG), so that no daemon outlives a test that was killed."""
    ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)


def start(name, argv, log):
    out = open(log + ".out", "w")
    p = subprocess.Popen(argv, env=env, stdout=out, stderr=subprocess.STDOUT,
                         preexec_fn=die_with_parent)
    daemons.append((name, p, log))
    return p


def main():
    for prog in ["munged", "slurmctld", "slurmd", "sbatch", "squeue", "sinfo"]:
        if shutil.which(prog) is None and not os.path.exists("/usr/sbin/" + prog):
            skip("%s not found (Debian packages munge and slurm-wlm)" % prog)
    sbin = lambda prog: shutil.which(prog) or "/usr/sbin/" + prog  # noqa: E731
    local = os.path.join(WORK, "local", "results.json")
    if not os.path.exists(local):
        fail(local + " missing: the case local of check_sweep.py runs first")

    # munge: a key in a private folder, the socket in an open one.
    # munged wants every folder above its socket open to all (x), and its key private.
    os.chmod(tmp, 0o755)
    keydir, sockdir = os.path.join(tmp, "key"), os.path.join(tmp, "munge")
    os.makedirs(keydir, mode=0o700)
    os.makedirs(sockdir, mode=0o755)
    key = os.path.join(keydir, "munge.key")
    with open(key, "wb") as f:
        f.write(os.urandom(1024))
    os.chmod(key, 0o600)
    munge_sock = os.path.join(sockdir, "munge.socket")
    munge_log = os.path.join(tmp, "munged.log")
    munged = start("munged", [sbin("munged"), "-F", "--key-file=" + key,
                              "--socket=" + munge_sock,
                              "--pid-file=" + os.path.join(sockdir, "munged.pid"),
                              "--log-file=" + munge_log,
                              "--seed-file=" + os.path.join(keydir, "munged.seed")], munge_log)
    for _ in range(50):
        if os.path.exists(munge_sock) or munged.poll() is not None:
            break
        time.sleep(0.1)
    if not os.path.exists(munge_sock):
        skip("munged did not start (status %s)" % munged.poll(), munge_log)

    host = socket.gethostname().split(".")[0]
    user = getpass.getuser()
    ctld_port, d_port = free_ports(2)
    for d in ["state", "spool"]:
        os.makedirs(os.path.join(tmp, d))
    conf = f"""ClusterName=nvstest
SlurmctldHost={host}
SlurmUser={user}
SlurmdUser={user}
SlurmctldPort={ctld_port}
SlurmdPort={d_port}
AuthType=auth/munge
AuthInfo=socket={munge_sock}
CredType=cred/munge
StateSaveLocation={tmp}/state
SlurmdSpoolDir={tmp}/spool
SlurmctldPidFile={tmp}/slurmctld.pid
SlurmdPidFile={tmp}/slurmd.pid
SlurmctldLogFile={tmp}/slurmctld.log
SlurmdLogFile={tmp}/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/builtin
SchedulerParameters=batch_sched_delay=0
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
ReturnToService=2
SlurmdParameters=config_overrides
NodeName={host} CPUs=2 State=UNKNOWN
PartitionName=test Nodes={host} Default=YES MaxTime=INFINITE State=UP
"""
    with open(env["SLURM_CONF"], "w") as f:
        f.write(conf)
    ctld_log, d_log = os.path.join(tmp, "slurmctld.log"), os.path.join(tmp, "slurmd.log")
    ctld = start("slurmctld", [sbin("slurmctld"), "-D", "-i"], ctld_log)
    time.sleep(1.0)
    slurmd = start("slurmd", [sbin("slurmd"), "-D"], d_log)
    state = ""
    for _ in range(60):
        for name, p, log in daemons:
            if p.poll() is not None:
                skip("%s exited with status %d at start" % (name, p.returncode), log)
        r = subprocess.run(["sinfo", "--noheader", "--format", "%t", "--nodes", host], env=env,
                           capture_output=True, text=True)
        state = r.stdout.strip()
        if r.returncode == 0 and state == "idle":
            break
        time.sleep(0.5)
    else:
        skip("the node did not become idle in 30 s (sinfo: %r)" % state, d_log)
    if os.geteuid() != 0:
        # slurmd not run by root may not be able to start jobs: a probe first.
        r = subprocess.run(["sbatch", "--wait", "--wrap", "true", "-o", "/dev/null"], env=env,
                           capture_output=True, text=True, timeout=60)
        if r.returncode != 0:
            skip("not root, and a probe job failed (sbatch status %d: %s)" %
                 (r.returncode, r.stderr.strip()), d_log)

    out = os.path.join(WORK, "slurm")
    shutil.rmtree(out, ignore_errors=True)
    t0 = time.time()
    p = subprocess.run([NVSTIM, "sweep", SPEC, "--out", out, "--slurm"], env=env,
                       capture_output=True, text=True, timeout=300)
    took = time.time() - t0
    if p.returncode != 0:
        fail("nvstim sweep --slurm: status %d\n%s\nslurmctld: %s\nslurmd: %s" %
             (p.returncode, p.stderr[-3000:], tail(ctld_log), tail(d_log)))
    if "submitted job array" not in p.stderr:
        fail("no submission line: " + p.stderr[-500:])
    with open(os.path.join(out, "slurm", "sweep.sbatch")) as f:
        script = f.read()
    if "#SBATCH --array=0-23\n" not in script or "--task \"$SLURM_ARRAY_TASK_ID\"" not in script:
        fail("sbatch script:\n" + script)
    with open(local) as f:
        a = json.load(f)
    with open(os.path.join(out, "results.json")) as f:
        b = json.load(f)
    skipped = set(a["timing_columns"]) | {"host"}
    compared = [c for c in a["columns"] if c not in skipped]
    if a["columns"] != b["columns"] or len(a["rows"]) != 24 or len(b["rows"]) != 24:
        fail("tables differ in shape: %s / %s" % (a["columns"], b["columns"]))
    for ra, rb in zip(a["rows"], b["rows"]):
        for c in compared:
            if ra.get(c) != rb.get(c):
                fail("row %d column %s: local %r, slurm %r" % (ra["index"], c, ra.get(c),
                                                                rb.get(c)))
    tasks = [n for n in os.listdir(os.path.join(out, "slurm")) if n.startswith("task-")]
    if len(tasks) != 24:
        fail("%d array task outputs, expected 24" % len(tasks))
    print("slurm: job array of 24 tasks on %s in %.1f s; the table equals the local one in %d "
          "columns (%s left out)" % (host, took, len(compared), ", ".join(sorted(skipped))))


main()
