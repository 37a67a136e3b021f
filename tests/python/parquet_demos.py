"""Write Parquet demonstrations files with pandas and pyarrow, for tests/bags.rs.

    parquet_demos.py CSV OUTDIR

From the CSV demonstrations file (read with pandas, every number parsed to the nearest double,
as advise parses them), writes OUTDIR/good.parquet (pandas' `to_parquet`, the episode labels as
text, several row groups), OUTDIR/good-f32.parquet (pyarrow, the numbers as float32), and one file
for each way a file can be wrong: a null, an integer `t`, a NaN action, an action beyond its
limits, a misspelled column, a missing column, an episode split in two.
"""

import sys

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq


def main():
    src, out = sys.argv[1], sys.argv[2]
    df = pd.read_csv(src, float_precision='round_trip', dtype={'episode': str})
    df.to_parquet(f'{out}/good.parquet', index=False, row_group_size=700)
    t = pa.Table.from_pandas(df, preserve_index=False)
    f32 = t.cast(pa.schema([pa.field(n, pa.string() if n == 'episode' else pa.float32())
                            for n in t.column_names]))
    pq.write_table(f32, f'{out}/good-f32.parquet')

    bad = df.copy()
    bad.loc[5, 'rot'] = None
    bad.to_parquet(f'{out}/null.parquet', index=False)
    bad = df.copy()
    bad['t'] = np.arange(len(bad), dtype=np.int64)
    bad.to_parquet(f'{out}/int-t.parquet', index=False)
    # pyarrow from numpy keeps a NaN a NaN (pandas would write it as a null).
    trans = df['trans'].to_numpy(copy=True)
    trans[7] = np.nan
    pq.write_table(t.set_column(t.column_names.index('trans'), 'trans', pa.array(trans)),
                   f'{out}/nan.parquet')
    bad = df.copy()
    bad.loc[9, 'trans'] = 40.0
    bad.to_parquet(f'{out}/limits.parquet', index=False)
    df.rename(columns={'bearing': 'baering'}).to_parquet(f'{out}/misspelled.parquet', index=False)
    df.drop(columns=['rot']).to_parquet(f'{out}/missing.parquet', index=False)
    first = df['episode'].iloc[0]
    rest = df[df['episode'] != first]
    mine = df[df['episode'] == first]
    half = len(mine) // 2
    pd.concat([mine.iloc[:half], rest, mine.iloc[half:]]).to_parquet(
        f'{out}/split.parquet', index=False)


if __name__ == '__main__':
    main()
