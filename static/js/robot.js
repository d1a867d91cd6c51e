import * as THREE from 'three';
import { SimplifyModifier } from 'three/addons/modifiers/SimplifyModifier.js';
import { vertexLitMaterial } from './vertex_lit.js';
import { mergedLinkGeometry } from './merged_links.js';
import { Trail } from './trail.js';

const PALETTE = [ 0x2f6fd6, 0xf07a1a, 0x17a08f, 0x9b4dca, 0xd6405a, 0x6b8e23 ];
const TCP_RADIUS = 0.012;
const STAND_IN_RADIUS = 0.022; // m: links without a mesh are drawn as ball and stick
const POSE = 7;

const _hsl = { h: 0, s: 0, l: 0 };
const _box = new THREE.Box3();
const _a = new THREE.Vector3();
const _b = new THREE.Vector3();
const _up = new THREE.Vector3( 0, 1, 0 );

// One grey for every robot that is not live (no frame yet, in error, source down).
const GREY = new THREE.MeshStandardMaterial( { color: 0xa3a8b0, roughness: 0.85, metalness: 0, transparent: true, opacity: 0.6 } );
GREY.userData.wholeLink = true; // the 2D view draws every part of a link in it (view2d/)
const _simple = new WeakMap(); // PBR material -> its Lambert stand-in
const _coarse = new WeakMap(); // geometry -> Promise of its simplified copy
const SIMPLE_SHARE = 0.15; // of a mesh's vertices kept at the lowest quality
let _simplifier = null;

// Software rendering also pays per triangle: SwiftShader sets triangles up in small
// batches, and the links' triangles were the largest part of a frame in Chromium's
// default path (bench/page_fps.py). The lowest level draws each mesh with about a
// seventh of its vertices (meshoptimizer through three's SimplifyModifier; fast, and
// shared by every mesh using the same geometry): a link some 100 px tall on screen keeps
// its silhouette with a few hundred triangles. From a third to a seventh saved 4.6 ms of
// the GPU process's CPU per frame (A/B, 4 runs each).
function coarseGeometry( geometry ) {

	let coarse = _coarse.get( geometry );
	if ( coarse === undefined ) {

		if ( _simplifier === null ) _simplifier = new SimplifyModifier();
		const count = geometry.attributes.position.count;
		coarse = count < 200
			? Promise.resolve( geometry )
			: _simplifier.modify( geometry, Math.floor( count * ( 1 - SIMPLE_SHARE ) ) ).catch( ( err ) => {

				console.warn( 'linkview: could not simplify a mesh; drawing it whole', err );
				return geometry;

			} );
		_coarse.set( geometry, coarse );

	}
	return coarse;

}

// Lambert costs a fraction of PBR per pixel, which is what software rendering
// runs out of first; colour and transparency are kept, so robots stay recognisable.
function simpleMaterial( material ) {

	let simple = _simple.get( material );
	if ( simple === undefined ) {

		simple = new THREE.MeshLambertMaterial( {
			color: material.color, transparent: material.transparent, opacity: material.opacity, side: material.side,
		} );
		_simple.set( material, simple );

	}
	return simple;

}

/** Set `object`'s pose from 7 numbers [x, y, z, qx, qy, qz, qw] of `array` at `offset`. */
function setPose( object, array, offset = 0 ) {

	object.position.set( array[ offset ], array[ offset + 1 ], array[ offset + 2 ] );
	object.quaternion.set( array[ offset + 3 ], array[ offset + 4 ], array[ offset + 5 ], array[ offset + 6 ] );

}

/** Link poses as one flat array, 7 numbers per link, from flat or nested input. */
function flatPoses( links ) {

	if ( links.length === 0 || typeof links[ 0 ] === 'number' ) return links;
	const flat = new Float32Array( links.length * POSE );
	links.forEach( ( pose, i ) => flat.set( pose, i * POSE ) );
	return flat;

}

/**
 * One robot of the cell, built from its `robot` entry of `hello`: a Group at the
 * robot's base pose with one child Object3D per link (in hello order, carrying
 * that link's mesh, whose origin is the link frame, or, where no link of the
 * robot has one, a ball-and-stick stand-in), a TCP marker and the TCP trail. Frames set the link
 * and TCP poses, which are given in the robot base frame.
 */
class RobotView {

	constructor( robot, index ) {

		this.name = robot.name;
		this.info = robot;
		this.index = index;
		this.color = new THREE.Color( PALETTE[ index % PALETTE.length ] );

		this.group = new THREE.Group();
		this.group.name = robot.name;
		setPose( this.group, robot.base );
		// Hidden until it has a pose: the zero pose from /fk, or a frame.
		this.group.visible = false;
		this.shown = true; // the operator's show/hide choice

		this.nodes = robot.links.map( ( link ) => {

			const node = new THREE.Object3D();
			node.name = link.name;
			this.group.add( node );
			return node;

		} );

		this.tcp = this._makeTcpMarker();
		this.group.add( this.tcp );
		this.trail = new Trail( this.color );
		this.group.add( this.trail.line );
		this.trailOn = true;
		this._sticks = []; // [cylinder, from node, to object] of stand-ins
		this._materials = new Map(); // link mesh -> its own material
		this._geometries = new Map(); // link mesh (from a mesh file) -> its own geometry
		this._linkOf = new Map(); // link mesh (from a mesh file) -> its link's index
		this._merged = null; // lowest level: one mesh per link, [Mesh | null] by link
		this._merging = null; // while the simplified parts are being made
		this._vertexColored = null; // their material (in colour)
		this.greyed = false;
		this.simple = false;

		this.framesApplied = 0;
		this.framesReceived = 0; // counted on arrival, before coalescing
		this.lastFrame = null; // newest frame, good or not
		this.goodFrame = null; // newest frame with ok = true: what the view shows
		this.zeroPosed = false; // drawn at the zero pose (no frame yet)
		this.error = null;
		this.note = null; // why it is grey, shown beside it (null while live)
		this.latencyMs = null; // sample to screen, smoothed
		this.anchor = null; // world point above the robot for its label

	}

	_makeTcpMarker() {

		const marker = new THREE.Group();
		marker.name = 'tcp';
		this._tcpMaterial = new THREE.MeshBasicMaterial( {
			color: this.color, depthTest: false, transparent: true, opacity: 0.9
		} );
		// Flat colour, so only the outline shows: 16 x 8 segments draw it as round as 24 x 12,
		// with 224 triangles, not 528, for software WebGL to set up each frame.
		const ball = new THREE.Mesh( new THREE.SphereGeometry( TCP_RADIUS, 16, 8 ), this._tcpMaterial );
		ball.renderOrder = 10;
		const axes = new THREE.AxesHelper( 0.06 );
		axes.material.depthTest = false;
		axes.renderOrder = 11;
		marker.add( ball, axes );
		return marker;

	}

	/** Load every link mesh with `loadMesh(url) -> Promise<Object3D>`; resolves once all are in. */
	async load( loadMesh ) {

		const meshes = await Promise.all( this.info.links.map( ( link ) => link.mesh ? loadMesh( link.mesh ) : null ) );
		// A robot that brings meshes draws nothing for its other links (a URDF link
		// without a visual); one without any gets stand-ins, to be seen at all.
		const bare = meshes.every( ( mesh ) => mesh === null );
		meshes.forEach( ( mesh, i ) => {

			if ( mesh === null ) {

				if ( bare ) this._addStandIn( i );
				return;

			}
			mesh.traverse( ( child ) => {

				if ( child.isMesh ) {

					child.castShadow = true;
					child.receiveShadow = true;
					this._materials.set( child, child.material );
					this._geometries.set( child, child.geometry );
					this._linkOf.set( child, i );

				}

			} );
			this.nodes[ i ].add( mesh );

		} );
		this._pickColor();
		this._updateSticks();
		this._applyMaterials();

	}

	// A ball at the link frame and a stick to the next link (or the TCP).
	_addStandIn( i ) {

		if ( ! this._standIn ) {

			this._standIn = new THREE.MeshStandardMaterial( { color: this.color, roughness: 0.5, metalness: 0.1 } );
			this._ball = new THREE.SphereGeometry( STAND_IN_RADIUS, 20, 12 );
			this._stick = new THREE.CylinderGeometry( STAND_IN_RADIUS * 0.55, STAND_IN_RADIUS * 0.55, 1, 14 );
			this._stick.translate( 0, 0.5, 0 ); // from its base at 0 to its tip at 1 along +Y

		}
		const ball = new THREE.Mesh( this._ball, this._standIn );
		ball.name = 'stand-in';
		ball.castShadow = true;
		this.nodes[ i ].add( ball );
		const stick = new THREE.Mesh( this._stick, this._standIn );
		stick.name = 'stand-in stick';
		stick.castShadow = true;
		this.group.add( stick );
		this._materials.set( ball, this._standIn );
		this._materials.set( stick, this._standIn );
		this._sticks.push( [ stick, this.nodes[ i ], i + 1 < this.nodes.length ? this.nodes[ i + 1 ] : this.tcp ] );

	}

	_updateSticks() {

		for ( const [ stick, from, to ] of this._sticks ) {

			_a.copy( from.position );
			_b.copy( to.position ).sub( _a );
			const length = _b.length();
			stick.visible = length > 1e-6;
			if ( ! stick.visible ) continue;
			stick.position.copy( _a );
			stick.quaternion.setFromUnitVectors( _up, _b.divideScalar( length ) );
			stick.scale.set( 1, length, 1 );

		}

	}

	/**
	 * The robot's colour is the most saturated of its materials, weighted by the
	 * size of the parts wearing it, so HUD, label and TCP marker match the meshes.
	 */
	_pickColor() {

		const weights = new Map(); // material -> summed weight
		this.group.traverse( ( child ) => {

			const material = this._materials.get( child );
			if ( ! material || ! material.color || material === this._standIn ) return;
			material.color.getHSL( _hsl );
			if ( _hsl.s < 0.3 || _hsl.l < 0.08 ) return;
			if ( child.geometry.boundingSphere === null ) child.geometry.computeBoundingSphere();
			const radius = child.geometry.boundingSphere.radius;
			weights.set( material, ( weights.get( material ) || 0 ) + _hsl.s * radius * radius );

		} );
		let best = null;
		for ( const [ candidate, weight ] of weights ) if ( best === null || weight > weights.get( best ) ) best = candidate;
		if ( best ) this.color.copy( best.color );
		this._tcpMaterial.color.copy( this.color );
		this.trail.material.color.copy( this.color );

	}

	/** Grey (not live: no frame yet, in error, or its source is down) or in colour. */
	setGreyed( greyed ) {

		if ( greyed === this.greyed ) return;
		this.greyed = greyed;
		this._applyMaterials();

	}

	/** Cheap Lambert shading instead of the meshes' PBR materials (the lowest quality level). */
	setSimple( simple ) {

		if ( simple === this.simple ) return;
		this.simple = simple;
		this._applyMaterials();

	}

	_applyMaterials() {

		for ( const [ mesh, own ] of this._materials ) {

			const base = this.greyed ? GREY : own;
			mesh.material = this.simple ? simpleMaterial( base ) : base;

		}
		for ( const merged of this._merged ?? [] ) if ( merged ) merged.material = this._mergedMaterial();
		this._applyGeometries();

	}

	_mergedMaterial() {

		if ( this.greyed ) return simpleMaterial( GREY );
		this._vertexColored ??= vertexLitMaterial();
		return this._vertexColored;

	}

	// The simplified geometry arrives asynchronously; whichever mode holds when it does wins.
	_applyGeometries() {

		if ( ! this.simple ) {

			this._unmerge();
			for ( const [ mesh, own ] of this._geometries ) mesh.geometry = own;
			return;

		}
		const meshes = [ ...this._geometries.keys() ];
		if ( this._merged || this._merging || meshes.length === 0 ) return; // meshes still loading: load() calls again
		this._merging = Promise.all( meshes.map( ( mesh ) => coarseGeometry( this._geometries.get( mesh ) ) ) ).then( ( coarse ) => {

			this._merging = null;
			if ( ! this.simple || this._merged || this._geometries.size !== meshes.length ) return;
			const parts = this.nodes.map( () => [] );
			meshes.forEach( ( mesh, k ) => parts[ this._linkOf.get( mesh ) ].push( [ mesh, coarse[ k ], this._materials.get( mesh ).color ] ) );
			this._merged = this.nodes.map( ( node, i ) => {

				const geometry = mergedLinkGeometry( node, parts[ i ] );
				if ( geometry === null ) return null;
				const merged = new THREE.Mesh( geometry, this._mergedMaterial() );
				merged.name = 'merged link';
				merged.castShadow = true;
				node.add( merged );
				return merged;

			} );
			for ( const mesh of meshes ) mesh.visible = false;

		} );

	}

	_unmerge() {

		if ( ! this._merged ) return;
		for ( const merged of this._merged ) {

			if ( ! merged ) continue;
			merged.removeFromParent();
			merged.geometry.dispose();

		}
		this._merged = null;
		for ( const mesh of this._geometries.keys() ) mesh.visible = true;

	}

	/** Show link poses (flat or nested, base frame) and the TCP pose. */
	setPoses( links, tcp ) {

		const poses = flatPoses( links );
		const count = Math.min( poses.length / POSE, this.nodes.length );
		for ( let i = 0; i < count; i ++ ) setPose( this.nodes[ i ], poses, i * POSE );
		if ( tcp && tcp.length === POSE ) setPose( this.tcp, tcp );
		this._updateSticks();
		this.group.visible = this.shown;

	}

	/** Draw the robot at its zero pose until its first frame (from /fk). */
	setZeroPose( links, tcp ) {

		if ( this.goodFrame !== null ) return;
		this.setPoses( links, tcp );
		this.zeroPosed = true;

	}

	/** Apply `frame` (already the newest for this robot); a frame that is not ok keeps the last pose. */
	apply( frame, timeMs ) {

		this.lastFrame = frame;
		if ( ! frame.ok ) {

			this.error = frame.error || 'the server could not compute this pose';
			return;

		}
		this.error = null;
		this.goodFrame = frame;
		this.zeroPosed = false;
		this.setPoses( frame.links, frame.tcp );
		if ( frame.tcp.length === POSE ) this.trail.add( frame.tcp[ 0 ], frame.tcp[ 1 ], frame.tcp[ 2 ], timeMs );
		this.framesApplied ++;

	}

	/** Whether it has a pose to show (a frame, or the zero pose). */
	get posed() {

		return this.goodFrame !== null || this.zeroPosed;

	}

	/** How many links are drawn as ball-and-stick stand-ins (none where the robot brings meshes). */
	get standIns() {

		return this._sticks.length;

	}

	setShown( shown ) {

		this.shown = shown;
		this.group.visible = shown && this.posed;

	}

	setTrail( on ) {

		this.trailOn = on;
		this.trail.line.visible = on;
		if ( ! on ) this.trail.clear();

	}

	/** World matrices of the links (hello order), each as 16 numbers (column-major). */
	linkMatrices() {

		this.group.updateWorldMatrix( true, true );
		return this.nodes.map( ( node ) => Array.from( node.matrixWorld.elements ) );

	}

	/** The robot's bounding box in the world (empty when hidden or not posed). */
	worldBox( target ) {

		target.makeEmpty();
		if ( ! this.group.visible ) return target;
		this.trail.line.visible = false; // the trail is no part of the robot's size
		target.setFromObject( this.group );
		this.trail.line.visible = this.trailOn;
		return target;

	}

	/** Move the label's anchor to just above the robot's current bounding box (world frame). */
	updateAnchor() {

		if ( ! this.group.visible ) return;
		this.worldBox( _box );
		if ( _box.isEmpty() ) return;
		if ( this.anchor === null ) this.anchor = new THREE.Vector3();
		this.anchor.set( ( _box.min.x + _box.max.x ) / 2, ( _box.min.y + _box.max.y ) / 2, _box.max.z + 0.04 );

	}

	/**
	 * A translucent copy of the robot's links for previewing a configuration:
	 * `{ group, setPoses(links, tcp), setLook(selected, outside), linkMatrices(), dispose() }`.
	 * Ball-and-stick stand-ins get their sticks too (to the next link, or to `tcp` when given).
	 */
	makeGhost() {

		const group = new THREE.Group();
		group.name = `${this.name} ghost`;
		setPose( group, this.info.base );
		const material = new THREE.MeshStandardMaterial( {
			color: this.color, transparent: true, opacity: 0.25, depthWrite: false, roughness: 0.6,
		} );
		material.userData.wholeLink = true; // as GREY
		const nodes = this.nodes.map( ( node ) => {

			const copy = new THREE.Object3D();
			for ( const child of node.children ) {

				const clone = child.clone( true );
				clone.traverse( ( part ) => {

					if ( part.isMesh ) {

						part.material = material;
						part.castShadow = false;
						part.receiveShadow = false;

					}

				} );
				copy.add( clone );

			}
			group.add( copy );
			return copy;

		} );
		const tcp = new THREE.Object3D();
		group.add( tcp );
		const sticks = this._sticks.map( ( [ stick, from, to ] ) => {

			const copy = new THREE.Mesh( stick.geometry, material );
			group.add( copy );
			const next = to === this.tcp ? tcp : nodes[ this.nodes.indexOf( to ) ];
			return [ copy, nodes[ this.nodes.indexOf( from ) ], next ];

		} );
		const color = this.color.clone();
		return {
			group,
			setPoses( links, tcpPose = null ) {

				const poses = flatPoses( links );
				const count = Math.min( poses.length / POSE, nodes.length );
				for ( let i = 0; i < count; i ++ ) setPose( nodes[ i ], poses, i * POSE );
				const withTcp = tcpPose !== null && tcpPose.length === POSE;
				if ( withTcp ) setPose( tcp, tcpPose );
				for ( const [ stick, from, to ] of sticks ) {

					_a.copy( from.position );
					_b.copy( to.position ).sub( _a );
					const length = _b.length();
					stick.visible = length > 1e-6 && ( withTcp || to !== tcp ); // no TCP given: no stick to it
					if ( ! stick.visible ) continue;
					stick.position.copy( _a );
					stick.quaternion.setFromUnitVectors( _up, _b.divideScalar( length ) );
					stick.scale.set( 1, length, 1 );

				}

			},
			setLook( selected, outside ) {

				material.color.set( outside ? 0xd6352b : color );
				material.opacity = selected ? 0.5 : 0.2;

			},
			/** World matrices of the ghost's links (hello order), 16 numbers each (column-major). */
			linkMatrices() {

				group.updateWorldMatrix( true, true );
				return nodes.map( ( node ) => Array.from( node.matrixWorld.elements ) );

			},
			dispose() {

				group.removeFromParent();
				material.dispose();

			},
		};

	}

	dispose() {

		this.group.removeFromParent();
		this._unmerge();
		this._vertexColored?.dispose();
		this.trail.dispose();
		this.tcp.traverse( ( child ) => {

			if ( child.geometry ) child.geometry.dispose();
			if ( child.material ) child.material.dispose();

		} );
		if ( this._standIn ) {

			this._standIn.dispose();
			this._ball.dispose();
			this._stick.dispose();

		}

	}

}

export { RobotView };
