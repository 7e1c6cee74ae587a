"""Shots: frame ranges rendered in this process or on a Dask cluster, bit-identical either way.

    frames.py   frame ranges ('1:24', '1:100:5') and output names ('shot.####.exr', 'shot.%04d.exr')
    plan.py     frames, tiles and sample ranges as tasks; split frames put back bit for bit
    worker.py   what a task does: the stage at a time code (static gprims kept), the scene
                (prototype BVHs reused), a render of a frame, a sample range or a tile
    events.py   progress of running tasks: Dask events from the workers, a tally on the client
    run.py      the shot: probe, resume, tasks in-process or on Dask, atomic frames, progress, summary
"""
