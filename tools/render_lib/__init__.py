"""tools/render's parts: common (messages, labels, the run's pipeline, saving), frames (a frame of
particles), plots (observables, CSV columns, the cluster-size distribution)."""
