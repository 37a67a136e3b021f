"""Read a LeRobot dataset's tables with pyarrow, for tests/bags.rs.

    read_lerobot.py DIR

Prints JSON: each table's schema (column name to pyarrow type) and rows, and `loader_task`: each
frame's task as LeRobot's v3.0 loader reads it (`load_tasks` is `pd.read_parquet` of
tasks.parquet; `__getitem__` sets `item["task"] = meta.tasks.iloc[task_index].name`).
"""

import json
import sys

import pyarrow.parquet as pq


def table(path):
    t = pq.read_table(path)
    return {'schema': {f.name: str(f.type) for f in t.schema}, 'rows': t.to_pylist()}


def loader_task(d):
    import pandas as pd

    tasks = pd.read_parquet(f'{d}/meta/tasks.parquet')
    frames = pq.read_table(f'{d}/data/chunk-000/file-000.parquet').to_pandas()
    return [tasks.iloc[int(i)].name for i in frames['task_index']]


def main():
    d = sys.argv[1]
    json.dump(
        {
            'loader_task': loader_task(d),
            'data': table(f'{d}/data/chunk-000/file-000.parquet'),
            'episodes': table(f'{d}/meta/episodes/chunk-000/file-000.parquet'),
            'tasks': table(f'{d}/meta/tasks.parquet'),
        },
        sys.stdout,
    )


if __name__ == '__main__':
    main()
