"""ESRI ASCII grids (.asc) as Firn's rasters and the benchmarks' DEMs write them."""
import numpy as np


def read_asc(path):
    """An ESRI ASCII grid (header keys, then the rows from the north, wrapped at any length) as
    rows from the south, nodata as NaN."""
    header, values = {}, []
    with open(path, encoding="ascii") as f:
        for line in f:
            fields = line.split()
            if fields and fields[0][0].isalpha():
                header[fields[0].lower()] = float(fields[1])
            else:
                values.extend(float(v) for v in fields)
    data = np.array(values).reshape(int(header["nrows"]), int(header["ncols"]))[::-1]
    if "nodata_value" in header:
        data = np.where(data == header["nodata_value"], np.nan, data)
    return header, data
