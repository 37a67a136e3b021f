"""Read a LeRobot dataset's tables with pyarrow, for tests/bags.rs.

    read_lerobot.py DIR

Prints JSON: each table's schema (column name to pyarrow type) and rows.
"""

import json
import sys

import pyarrow.parquet as pq


def table(path):
    t = pq.read_table(path)
    return {'schema': {f.name: str(f.type) for f in t.schema}, 'rows': t.to_pylist()}


def main():
    d = sys.argv[1]
    json.dump(
        {
            'data': table(f'{d}/data/chunk-000/file-000.parquet'),
            'episodes': table(f'{d}/meta/episodes/chunk-000/file-000.parquet'),
            'tasks': table(f'{d}/meta/tasks.parquet'),
        },
        sys.stdout,
    )


if __name__ == '__main__':
    main()
