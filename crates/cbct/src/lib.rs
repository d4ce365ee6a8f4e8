//! CBCT volumes: readers, phantom, calibration, segmentation (arriving with issue 3).
