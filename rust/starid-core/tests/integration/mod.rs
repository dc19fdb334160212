mod geometry;
mod identify;
mod kvector;
mod strategies;
