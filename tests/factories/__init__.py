"""Shared synthetic-data factories of the tests and benchmarks, one module per data kind.

Each module builds data with a known ground truth from a seed (the same seed gives the same
data):

- :mod:`.event_counts`: noisy per-polarity event counts of approach-press-slip-release
  trials (``make_trial``, ``random_timeline``, ``random_params``) and raw events with
  exactly those counts per bin (``events_from_counts``), in memory.
- :mod:`.press_regions`: areas of noisy press regions at the scene's 12 force levels
  (``press_areas``, ``expected_press``, ``level_alpha``, ``grades_of``), no events and no
  file; for the grader tests and ``benchmarks/grade_stability.py``.
- :mod:`.action_files`: action-classification files like `tactile synth` writes
  (``make_action_file``: counts streams with per-bin action labels and force labels) and
  raw-event trials with annotations (``make_event_file``).
- :mod:`.fos_counts`: files of trials with known first-order-system parameters, as a
  counts stream or as events (``write_counts_file``), and ``use_test_compilation_cache``
  for the tests that fit them with JAX.
- :mod:`.strip_events`: marker-strip events with a known slip speed (``make_strip_events``)
  and files of them (``write_trials``), with the sensor geometry ``W``, ``H``, ``OPTICS``
  and ``STRIP_ROIS``.

Pytest fixtures stay in the ``conftest.py`` of the tests that use them and build their data
here.
"""
