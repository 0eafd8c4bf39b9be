#!/usr/bin/env python3
"""CLEAR MOT of a multi-object sequence by py-motmetrics, the reference for tether's.

  motmetrics_reference.py SEQUENCE.json

SEQUENCE.json: {"threshold_m": 0.75, "frames": [{"objects": [[id, x, y], ...],
"hypotheses": [[id, x, y], ...]}, ...]}. Distances are Euclidean; pairs farther than
the threshold cannot match (NaN), as with motmetrics.distances.norm2squared_matrix but
not squared, so that MOTP is a mean distance in metres. Prints the figures as JSON.

Needs `pip install motmetrics`.
"""

import json
import sys

import motmetrics as mm
import numpy as np


def main() -> None:
    seq = json.load(open(sys.argv[1]))
    t = seq['threshold_m']
    acc = mm.MOTAccumulator(auto_id=True)
    for f in seq['frames']:
        o = np.array([[x, y] for _, x, y in f['objects']], dtype=float).reshape(-1, 2)
        h = np.array([[x, y] for _, x, y in f['hypotheses']], dtype=float).reshape(-1, 2)
        d = np.sqrt(((o[:, None, :] - h[None, :, :]) ** 2).sum(axis=2))
        d[d > t] = np.nan
        acc.update([i for i, _, _ in f['objects']], [i for i, _, _ in f['hypotheses']], d)
    names = ['num_objects', 'num_matches', 'num_switches', 'num_false_positives',
             'num_misses', 'num_detections', 'mota', 'motp']
    summary = mm.metrics.create().compute(acc, metrics=names, name='seq')
    out = {n: float(summary[n].iloc[0]) for n in names}
    json.dump(out, sys.stdout)


if __name__ == '__main__':
    main()
