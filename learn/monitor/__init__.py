"""A monitoring series: many tests of one beam, the normal variation learnt on a baseline period, a novelty index
per test with a cross-validated threshold (the library behind ``beam-damage monitor``).

Steps, one module each:

* :mod:`~learn.monitor.identification` -- one test's modes (FRFs by LSCF/LSFD, response records by SSI-cov,
  modal data read), :func:`cached_identification` keeping the result per file in a JSON cache keyed by the
  file's bytes and the settings;
* :mod:`~learn.monitor.series` -- the tests in time order with their measured conditions, and whether each
  belongs to the baseline period's series;
* :mod:`~learn.monitor.tracking` -- the baseline period's modes (clustered; a mode found in 15 % of the tests and 7
  of them is one, its presence reported) and each test's poles assigned to them one to one within each mode's band
  (from its baseline scatter) by frequency (and MAC with 2 or more sensors), a mode the identification missed
  identified again over its search band (:func:`refit_missing`), a mode missing in a test NaN there;
  :mod:`~learn.monitor.pole_confirmation` -- a tracked pole far beyond its mode's baseline scatter checked by that
  narrow band (a split mode read at the mode); :mod:`~learn.monitor.beyond_band` -- a mode missing from its band
  read moved or lost beyond it, weighed by the baseline's chance of that reading and of a run of them;
* :mod:`~learn.monitor.estimator_choice` -- each reference mode's frequency of response records by the more repeatable
  over the baseline period of the identification and the record's zero-padded FFT peak (the identification kept
  where its scatter over the baseline is the smaller);
* :mod:`~learn.monitor.normal_models` -- :data:`NORMAL_MODELS`, the normal variation of the features (log natural
  frequencies): a regression on measured conditions, or a latent-variable model (PCA with factors removed, factor
  analysis, a Gaussian mixture); each gives a squared Mahalanobis distance of a test's residual (the novelty index);
* :mod:`~learn.monitor.alarm_threshold` -- every baseline test's index by a model that did not see it
  (leave-one-out or k-fold) and the threshold of a false-alarm rate from a scaled F distribution fitted to them;
  :mod:`~learn.sessions` -- runs of baseline tests at one level (sessions), then held out a session at a
  time, the environment judged as one value per session;
* :mod:`~learn.monitor.baseline_outliers` -- a baseline test whose held-out index lies beyond the baseline's
  family-wise threshold (``rate / n``, the law fitted without it) named and left out of the baseline period;
* :mod:`~learn.monitor.statistics` -- the detector: the residual index, the environmental scores' ``T^2``, the
  signed common shift and, when chosen, the per-mode prediction interval (:mod:`~learn.monitor.per_mode`), each held
  out and thresholded, the false-alarm rate shared among them (``SHARES``) and calibrated on their joint held-out
  distribution (:func:`detect`; the level of the union of the held-out alarms: :mod:`~learn.monitor.union_calibration`);
  :mod:`~learn.monitor.seasons` -- whether a dated baseline period covers the seasons;
* :mod:`~learn.monitor.charts` -- memory: EWMA charts of the statistics with limits from the baseline's
  autocorrelation, and the onset of a change (:func:`run_charts`);
* :mod:`~learn.monitor.alarms` -- :func:`monitor_series`, all of it on a series (:class:`SeriesResult` holds the
  rows), and what changed at an alarm;
* :mod:`~learn.monitor.coverage` -- whether a later test lies beyond the baseline's conditions (extrapolated) and
  whether the later healthy-looking tests scatter more than the baseline's (a baseline period too narrow);
* :mod:`~learn.monitor.events` -- consecutive alarms and tests not identified grouped into events (the modes that
  moved, size, direction), and the tests not identified against the baseline's share (a binomial test);
* :mod:`~learn.monitor.verdicts` -- the competing explanations and the network's verdict of each event (or alarm);
* :mod:`~learn.monitor.workers` -- the tests identified over worker processes (results independent of their number);
* :mod:`~learn.monitor.baseline_state` -- the baseline's held-out indices kept beside the cache and reused while the
  baseline and the normal model are unchanged.
"""

from learn.monitor.alarm_threshold import (Threshold, held_out_novelty, minimum_baseline, missing_evidence,
                                           threshold)
from learn.monitor.alarms import STATUSES, SeriesResult, changed_text, monitor_series, what_changed
from learn.monitor.charts import CHARTS, Charts, run_charts
from learn.monitor.coverage import Coverage, Scatter, baseline_scatter, coverage, series_coverage
from learn.monitor.events import Event, group_events, identification_change
from learn.monitor.identification import (CACHE_FORMAT, IdentificationSettings, IdentifiedModes,
                                          cached_identification, file_key, identification_settings, identify_test,
                                          with_narrow_band_poles, write_cache)
from learn.monitor.normal_models import (DEFAULT_LATENT, NORMAL_MODELS, PCA_EXPLAINED, FactorRemoval, Mixture,
                                         PCARemoval, Regression)
from learn.monitor.series import SeriesInput, check_series, read_conditions
from learn.monitor.statistics import STATISTICS, Detection, detect
from learn.monitor.tracking import (MAC_MIN, MIN_COUNT, MIN_PRESENCE, ReferenceModes, identified_by, narrow_bands_hz,
                                   reference_modes, refit_missing, track_modes)
from learn.monitor.verdicts import alarm_verdicts, baseline_nearest_median, event_verdicts
from learn.monitor.workers import identify_files

__all__ = ["CACHE_FORMAT", "CHARTS", "Charts", "Coverage", "DEFAULT_LATENT", "Detection", "Event", "MAC_MIN",
           "MIN_COUNT", "MIN_PRESENCE", "NORMAL_MODELS", "PCA_EXPLAINED", "STATISTICS", "STATUSES", "Scatter",
           "alarm_verdicts", "baseline_nearest_median", "baseline_scatter", "cached_identification", "changed_text",
           "check_series", "coverage", "detect", "event_verdicts", "FactorRemoval", "file_key", "group_events",
           "held_out_novelty", "identification_change", "identification_settings", "IdentificationSettings",
           "IdentifiedModes", "identified_by", "identify_files", "identify_test", "minimum_baseline",
           "missing_evidence", "Mixture", "monitor_series", "narrow_bands_hz", "PCARemoval", "read_conditions",
           "reference_modes", "ReferenceModes", "refit_missing", "Regression", "run_charts", "SeriesInput",
           "SeriesResult", "series_coverage", "Threshold", "threshold", "track_modes", "what_changed",
           "with_narrow_band_poles", "write_cache"]
