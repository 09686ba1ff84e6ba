"""Files in and out: task sets, scenarios, atomic results, manifests."""
