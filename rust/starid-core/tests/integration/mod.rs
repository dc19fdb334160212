mod geometry;
mod identify;
mod kvector;
mod pointing;
mod seeds;
mod strategies;
mod unknown_focal;
