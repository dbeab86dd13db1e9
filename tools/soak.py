#!/usr/bin/env python3
"""Soak benchmark (issue 12; not run in CI): `heliar live --headless-frames` over a looped
sequence, with its resident memory (VmRSS) sampled every N frames or every S seconds.

Usage:
  python3 tools/soak.py [--bin target/release/heliar] [--minutes 30] [--scene scenes/courtyard]
                        [--sequence hdr] [--fps 10] [--every-frames 50 | --interval-s 60]
                        [--warmup-s 60] [--csv out/soak.csv] [--max-growth 0.05]
                        [--backend vulkan|gl] [-- EXTRA LIVE ARGS]

Prints a table (elapsed time, frames processed, RSS) while it runs and writes it as CSV. At the
end it reports the growth after the warm-up (the first sample after --warmup-s against the last),
the largest RSS after the warm-up, and the least-squares slope in MiB per frame and per minute.
Exit 0 when RSS after the warm-up grew by at most --max-growth (default 5%), 1 when it grew more,
2 when the run failed. Linux only (reads /proc). Frames are counted from the `frame …` lines
`live --headless-frames` prints.
"""
import argparse, csv, os, subprocess, sys, threading, time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def rss_mib(pid):
    try:
        with open(f'/proc/{pid}/status', encoding='ascii') as f:
            for line in f:
                if line.startswith('VmRSS:'):
                    return int(line.split()[1]) / 1024.0
    except (FileNotFoundError, ProcessLookupError):
        return None
    return None


def slope(xs, ys):
    """Least-squares slope of ys over xs (None with fewer than two distinct xs)."""
    n = len(xs)
    if n < 2:
        return None
    mx, my = sum(xs) / n, sum(ys) / n
    sxx = sum((x - mx) ** 2 for x in xs)
    if sxx == 0:
        return None
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sxx


class FrameCounter:
    """Counts the `frame …` lines of the run's stdout (and keeps the rest for the log)."""

    def __init__(self, stream, log):
        self.frames, self.lock = 0, threading.Lock()
        self.thread = threading.Thread(target=self._read, args=(stream, log), daemon=True)
        self.thread.start()

    def _read(self, stream, log):
        for line in stream:
            if line.startswith('frame '):
                with self.lock:
                    self.frames += 1
            else:
                log.write(line)

    def count(self):
        with self.lock:
            return self.frames


def summarise(rows, warmup_s, max_growth):
    """Prints the growth after the warm-up; returns the process exit code."""
    after = [r for r in rows if r[0] >= warmup_s]
    if len(after) < 2:
        print(f'too short to judge growth: {len(after)} sample(s) after the {warmup_s:.0f} s warm-up')
        return 0
    t0, f0, m0 = after[0]
    t1, f1, m1 = after[-1]
    peak = max(r[2] for r in after)
    growth = (peak - m0) / m0
    per_frame = slope([r[1] for r in after], [r[2] for r in after])
    per_min = slope([r[0] / 60.0 for r in after], [r[2] for r in after])
    print(f'after the warm-up ({t0:.0f} s, frame {f0}): RSS {m0:.1f} MiB; at the end ({t1:.0f} s, frame {f1}) {m1:.1f} MiB; peak {peak:.1f} MiB')
    print(f'growth after the warm-up {100 * growth:+.2f}% (limit {100 * max_growth:.0f}%)' + (f'; slope {per_frame:+.4f} MiB/frame' if per_frame is not None else '') + (f', {per_min:+.2f} MiB/min' if per_min is not None else ''))
    return 0 if growth <= max_growth else 1


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--bin', default=os.path.join(ROOT, 'target', 'release', 'heliar'))
    ap.add_argument('--minutes', type=float, default=30.0)
    ap.add_argument('--scene', default=os.path.join(ROOT, 'scenes', 'courtyard'))
    ap.add_argument('--sequence', default='hdr')
    ap.add_argument('--fps', type=float, default=10.0, help='pace of the looped input (frames the run cannot keep up with are dropped)')
    ap.add_argument('--every-frames', type=int, default=0, help='sample every N processed frames (default: by time)')
    ap.add_argument('--interval-s', type=float, default=60.0, help='sampling interval when not by frames (default one minute)')
    ap.add_argument('--warmup-s', type=float, default=60.0, help='growth is judged from the first sample after this')
    ap.add_argument('--csv', default=os.path.join(ROOT, 'out', 'soak.csv'))
    ap.add_argument('--max-growth', type=float, default=0.05)
    ap.add_argument('--backend', choices=['vulkan', 'gl'], help='WGPU_BACKEND for the run (default: what wgpu picks)')
    ap.add_argument('extra', nargs='*', help='more arguments for `heliar live` (after --)')
    a = ap.parse_args()
    if not os.path.exists(a.bin):
        sys.stderr.write(f'{a.bin}: no heliar binary (cargo build --release --features opencv)\n')
        return 2
    frames_dir = os.path.join(a.scene, 'frames', a.sequence)
    # More frames than the run can render in the time: the loop never ends on its own.
    cmd = [a.bin, 'live', a.scene, '--input', frames_dir, '--loop', '--fps', str(a.fps), '--headless-frames', str(10**9)] + a.extra
    env = dict(os.environ)
    if a.backend:
        env['WGPU_BACKEND'] = a.backend
    out_dir = os.path.dirname(a.csv) or '.'
    os.makedirs(out_dir, exist_ok=True)
    log = open(os.path.join(out_dir, 'soak.log'), 'w')
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=log, text=True, env=env)
    counter = FrameCounter(proc.stdout, log)
    rows, start, next_frames = [], time.time(), a.every_frames
    print(f'{"elapsed s":>9}  {"frames":>7}  {"RSS MiB":>8}', flush=True)
    try:
        k = 0
        while time.time() - start < a.minutes * 60.0:
            if a.every_frames > 0:
                time.sleep(0.05)
                if counter.count() < next_frames:
                    if proc.poll() is not None:
                        break
                    continue
                next_frames += a.every_frames
            else:
                time.sleep(max(0.0, start + (k + 1) * a.interval_s - time.time()))
                k += 1
            if proc.poll() is not None:
                break
            m = rss_mib(proc.pid)
            if m is None:
                break
            rows.append((time.time() - start, counter.count(), m))
            print(f'{rows[-1][0]:9.1f}  {rows[-1][1]:7d}  {m:8.1f}', flush=True)
        if proc.poll() is not None:
            sys.stderr.write(f'the run ended early (exit {proc.returncode}); see {log.name}\n')
            return 2
    finally:
        if proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()
        with open(a.csv, 'w', newline='') as f:
            w = csv.writer(f)
            w.writerow(['elapsed_s', 'frames', 'rss_mib'])
            w.writerows((f'{t:.1f}', n, f'{m:.1f}') for t, n, m in rows)
        print(f'wrote {a.csv} ({len(rows)} samples, {" ".join(cmd[1:])}, WGPU_BACKEND={env.get("WGPU_BACKEND", "default")})')
    return summarise(rows, a.warmup_s, a.max_growth)


if __name__ == '__main__':
    sys.exit(main())
