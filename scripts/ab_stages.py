#!/usr/bin/env python3
"""Stage times of two cdsm builds, run in turn (A B, B A, ...).

    scripts/ab_stages.py A/cdsm B/cdsm RUNS [SCENE] [-- extra render args]

Renders SCENE (default content/scenes/default.json) with
`--backend cpu --fragments cpu` plus the extra arguments, and prints one
Markdown row per stage of `times [ms]`: A's and B's medians [min-max] and the
median [min-max] of the pairwise ratios B / A. Alternating keeps the ratios
meaningful while the machine's speed drifts (docs/bench/README.md uses it for
the camera-pass A/Bs).
"""
import os
import re
import statistics as st
import subprocess
import sys
import tempfile

args = sys.argv[1:]
extra = []
if '--' in args:
    extra = args[args.index('--') + 1:]
    args = args[:args.index('--')]
if len(args) < 3:
    sys.exit(__doc__)
a, b, runs = args[0], args[1], int(args[2])
scene = args[3] if len(args) > 3 else os.path.join(os.path.dirname(__file__), '..', 'content', 'scenes', 'default.json')
stages = ['light fragments', 'DSM build', 'camera fragments', 'camera pass', 'frame']
times = [[], []]  # A's runs, B's runs
out_png = os.path.join(tempfile.mkdtemp(prefix='ab_stages.'), 'x.png')
for i in range(runs):
    for k in ([0, 1] if i % 2 == 0 else [1, 0]):
        exe = (a, b)[k]
        r = subprocess.run([exe, 'render', scene, '-o', out_png, '--backend', 'cpu', '--fragments', 'cpu'] + extra,
                           capture_output=True, text=True)
        if r.returncode != 0:
            sys.exit(f'{exe} failed ({r.returncode}):\n{r.stderr}')
        line = next(l for l in r.stdout.splitlines() if l.startswith('times'))
        times[k].append({s: float(re.search(s + r' ([\d.]+)', line).group(1)) for s in stages})
print('| stage | A | B | B / A |')
print('|---|---|---|---|')
for s in stages:
    x = [t[s] for t in times[0]]
    y = [t[s] for t in times[1]]
    q = [v / u for u, v in zip(x, y)]
    print(f'| {s} | {st.median(x):.1f} [{min(x):.1f}–{max(x):.1f}] | {st.median(y):.1f} [{min(y):.1f}–{max(y):.1f}] '
          f'| {st.median(q):.3f} [{min(q):.3f}–{max(q):.3f}] |')
