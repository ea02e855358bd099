"""Backend interfaces (hand, arm, tactile sensors) and their implementations."""
