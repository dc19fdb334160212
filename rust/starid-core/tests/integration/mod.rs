mod geometry;
mod identify;
mod kvector;
mod pointing;
mod seeds;
mod strategies;
mod tracking;
mod unknown_focal;
