"""roneld-eval's in-memory metrics (`roneld_eval.metric`) inside training frameworks: an mmengine
`BaseMetric` (`frameworks.mmengine_metric`) and a torchmetrics `Metric`
(`frameworks.torchmetrics_metric`), each a thin class over `in_memory.Metric`, installed with the
`[train]` extra. What a framework's data sample holds is read by `samples`."""
