mod geometry;
mod identify;
mod kvector;
mod pointing;
mod strategies;
mod unknown_focal;
