#!/usr/bin/env python3
"""Soak benchmark (issue 12; not run in CI): `heliar live` without a window over a looped
sequence for a stated time, with its resident memory sampled once a minute. The run passes when
memory after the first minute grows by at most --max-growth (default 5%).

Usage:
  python3 tools/soak.py [--bin target/release/heliar] [--minutes 30] [--scene scenes/courtyard]
                        [--sequence hdr] [--csv out/soak.csv] [--max-growth 0.05]

Prints a table (minute, RSS MiB, frames so far when the log tells) and writes it as CSV. Exit 0
when memory stayed flat, 1 when it grew, 2 when the run failed. Linux only (reads /proc).
"""
import argparse, csv, os, subprocess, sys, time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def rss_mib(pid):
    try:
        with open(f'/proc/{pid}/status', encoding='ascii') as f:
            for line in f:
                if line.startswith('VmRSS:'):
                    return int(line.split()[1]) / 1024.0
    except FileNotFoundError:
        return None
    return None


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--bin', default=os.path.join(ROOT, 'target', 'release', 'heliar'))
    ap.add_argument('--minutes', type=float, default=30.0)
    ap.add_argument('--scene', default=os.path.join(ROOT, 'scenes', 'courtyard'))
    ap.add_argument('--sequence', default='hdr')
    ap.add_argument('--csv', default=os.path.join(ROOT, 'out', 'soak.csv'))
    ap.add_argument('--max-growth', type=float, default=0.05)
    ap.add_argument('--interval-s', type=float, default=60.0, help='sampling interval (default one minute)')
    a = ap.parse_args()
    if not os.path.exists(a.bin):
        sys.stderr.write(f'{a.bin}: no heliar binary (cargo build --release)\n')
        return 2
    frames_dir = os.path.join(a.scene, 'frames', a.sequence)
    # More frames than the run can render in the time: the loop never ends on its own.
    cmd = [a.bin, 'live', a.scene, '--input', frames_dir, '--loop', '--headless-frames', str(10**9)]
    os.makedirs(os.path.dirname(a.csv) or '.', exist_ok=True)
    log = open(os.path.join(os.path.dirname(a.csv) or '.', 'soak.log'), 'w')
    proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT)
    rows, start = [], time.time()
    try:
        k = 0
        while time.time() - start < a.minutes * 60.0:
            time.sleep(max(0.0, start + (k + 1) * a.interval_s - time.time()))
            k += 1
            if proc.poll() is not None:
                sys.stderr.write(f'the run ended early (exit {proc.returncode}); see {log.name}\n')
                return 2
            m = rss_mib(proc.pid)
            rows.append((k * a.interval_s / 60.0, m))
            print(f'{rows[-1][0]:6.1f} min  RSS {m:8.1f} MiB', flush=True)
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
    with open(a.csv, 'w', newline='') as f:
        w = csv.writer(f)
        w.writerow(['minute', 'rss_mib'])
        w.writerows(rows)
    if len(rows) < 2:
        print('too short to judge growth (at least two samples needed)')
        return 0
    base = rows[0][1]
    peak = max(r[1] for r in rows[1:])
    growth = (peak - base) / base
    print(f'RSS after the first sample {base:.1f} MiB, peak later {peak:.1f} MiB: growth {100 * growth:+.2f}% (limit {100 * a.max_growth:.0f}%)')
    print(f'wrote {a.csv}')
    return 0 if growth <= a.max_growth else 1


if __name__ == '__main__':
    sys.exit(main())
