"""The foundations every layer of gyrotest stands on (docs/architecture.md): error types,
units, the earth rate, the in-memory log, the angle series θ, bench profiles, the schema checks
of small files, the output guard, atomic writes and JSON, the figure style, the stderr console.
Nothing here imports another gyrotest package."""
