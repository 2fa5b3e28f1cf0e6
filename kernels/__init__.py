"""OpenCL C sources of the megakernel, shipped as package data."""
