"""Shots: frame ranges rendered in this process or on a Dask cluster, bit-identical either way.

    frames.py   frame ranges ('1:24', '1:100:5') and output names ('shot.####.exr', 'shot.%04d.exr')
    plan.py     frames (and sample ranges of frames) as tasks; split frames put back bit for bit
    worker.py   what a task does: the stage at a time code, the scene (prototype BVHs reused), a render
    run.py      the shot: probe, resume, tasks in-process or on Dask, atomic frames, progress, summary
"""
