#!/usr/bin/env python3
"""What position-independent code costs the libraries' code (issue 32).

Builds kinematics_bench three ways from one source tree and runs the three
binaries alternately, round by round, so each ratio is measured in one run:
  A  Release without -fPIC (what the programs were built as before; Debian's
     g++ makes PIE executables)
  B  + -fPIC (CMAKE_POSITION_INDEPENDENT_CODE) alone
  C  + -fPIC -fno-semantic-interposition (what every tree builds since issue 32)
and prints, for ComputeFrameKinematics ("all") and every frame's Jacobian
("jacobians") on the Panda and the UR5, B/A and C/A: the ratio of each tree's
fastest sample (the machine is shared: the fastest is the least disturbed),
the median over rounds of the per-round ratio, and the same ratio for KDL's
call in the same binaries (a library none of the flags touch: its drift is
the noise). The flags are given so that they mean the same on a commit before
issue 32 (which had no PIC default) and after it.

  /usr/bin/python3 bench/pic_cost.py [--source .] [--trees build-pic] [--rounds 10]
"""
import argparse
import json
import os
import statistics
import subprocess
import sys

TREES = {
    'A': ['-DCMAKE_POSITION_INDEPENDENT_CODE=OFF'],
    'B': ['-DCMAKE_POSITION_INDEPENDENT_CODE=ON', '-DLAGRANGE_SEMANTIC_INTERPOSITION=ON'],
    'C': ['-DCMAKE_POSITION_INDEPENDENT_CODE=ON', '-DCMAKE_CXX_FLAGS=-fno-semantic-interposition'],
}
FILTER = 'kin/(panda|ur5)/(lagrange|kdl)/(all|jacobians)$'


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--source', default='.')
    ap.add_argument('--trees', default='build-pic', help='the three build trees go in TREES/A, B, C')
    ap.add_argument('--rounds', type=int, default=10)
    args = ap.parse_args()
    env = dict(os.environ, CMAKE_CXX_COMPILER_LAUNCHER='ccache', CMAKE_C_COMPILER_LAUNCHER='ccache')
    for t, flags in TREES.items():
        tree = os.path.join(args.trees, t)
        subprocess.run(['cmake', '-S', args.source, '-B', tree, '-DCMAKE_BUILD_TYPE=Release',
                        '-DLAGRANGE_BUILD_TESTS=OFF', '-DLAGRANGE_BUILD_BENCH=ON', '-DLAGRANGE_BUILD_PYTHON=OFF',
                        *flags], check=True, env=env, stdout=subprocess.DEVNULL)
        subprocess.run(['cmake', '--build', tree, '-j', str(os.cpu_count() or 2), '--target', 'kinematics_bench'],
                       check=True, env=env, stdout=subprocess.DEVNULL)
    samples = {}  # (tree, benchmark, round) -> [cpu ns]
    for r in range(args.rounds):
        for t in TREES:
            out = subprocess.run([os.path.join(args.trees, t, 'bench', 'kinematics_bench'),
                                  f'--benchmark_filter={FILTER}', '--benchmark_min_time=0.05',
                                  '--benchmark_repetitions=5', '--benchmark_format=json'],
                                 check=True, capture_output=True, text=True).stdout
            for b in json.loads(out)['benchmarks']:
                if b.get('run_type') == 'iteration':
                    samples.setdefault((t, b['run_name'], r), []).append(b['cpu_time'])

    def fastest(t, name):
        return min(min(v) for (tt, n, _), v in samples.items() if tt == t and n == name)

    print(f'pic_cost: kinematics_bench, {args.rounds} rounds of A, B, C in turn, 5 samples each')
    for robot in ('panda', 'ur5'):
        for term, what in (('all', 'ComputeFrameKinematics'), ('jacobians', "every frame's Jacobian")):
            name = f'kin/{robot}/lagrange/{term}'
            kdl = f'kin/{robot}/kdl/{term}'
            line = f'{robot:5} {what:23} A {fastest("A", name):6.1f} ns'
            for t in ('B', 'C'):
                per_round = statistics.median(min(samples[(t, name, r)]) / min(samples[('A', name, r)])
                                              for r in range(args.rounds))
                line += f' | {t}/A {fastest(t, name) / fastest("A", name):.3f} (rounds {per_round:.3f}'
                if any(n == kdl for (_, n, _) in samples):
                    line += f'; KDL {fastest(t, kdl) / fastest("A", kdl):.3f}'
                line += ')'
            print(line)
    return 0


if __name__ == '__main__':
    sys.exit(main())
