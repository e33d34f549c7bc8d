pub mod algo;
