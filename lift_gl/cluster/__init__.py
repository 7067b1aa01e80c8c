"""Renders of `lift-gl grade` and `lift-gl compare` on a Ray cluster (docs/cluster.md).

    lift-gl grade class/ --executor ray --address HEAD:6379 --out grades/

| module        | concern                                                                  |
| ------------- | ------------------------------------------------------------------------ |
| options.py    | --executor and --address on the commands (imports nothing heavy)         |
| shipping.py   | a plugin folder as bytes, and back into a folder on the worker           |
| worker.py     | RenderWorker: one a GPU or CPU slot; its GL context, its compiled renderers |
| pool.py       | the actors, tasks dispatched to idle ones, timeouts, lost workers retried |
| grade_tasks.py| grading split by submission x scene x seeds, merged back into SceneRuns  |
| compare_tasks.py | compare's runs (configuration x seed) on the pool                     |

Ray (pip install 'lift-gl[cluster]') is imported only by pool.py, when a pool is made.
"""
