"""Small synthetic raw recordings of every format `tactile ingest` reads.

Used by the tests (round trips: known content in, same content out) and by `make demo`.
Each writer returns the ground truth it wrote, so a caller can compare after ingest.
"""
